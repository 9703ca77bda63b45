//! The account of the work done on the model by changing the body forces' fields between runs
//! (gravity, the water table): the fields it last saw and the work booked since. Held by the
//! model; `body_potential.rs` books it.

use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// What the body forces' potential depends on: gravity and the water table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BodyFields {
    pub gravity: Vec3,
    /// The table's level (m); `None`: no water.
    pub level: Option<f64>,
    /// The fluid's density (kg/m³).
    pub density: f64,
}

/// The account of the body forces' fields: the fields the account last saw and the work done
/// by changing them since (J).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BodyWork {
    /// `None`: not yet seen (a new model: the first look books nothing).
    pub(crate) seen: Option<BodyFields>,
    /// Work done on the model by changing the fields (J): Σ over changes of the body potential
    /// with the new fields minus with the old, at the positions of the change.
    pub work: f64,
}

impl BodyWork {
    /// The account of a model loaded from a checkpoint older than format 8, which did not
    /// carry it: no work booked, and the fields the file holds taken as the ones seen (they
    /// are those of its last run unless a program wrote `settings` directly after it; a later
    /// change is then booked at the next run, which `None` would miss).
    pub(crate) fn from_fields(fields: BodyFields) -> Self {
        BodyWork { seen: Some(fields), work: 0.0 }
    }
}
