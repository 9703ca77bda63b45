//! The pore network's boundary conditions: which pores a region holds and what it does to
//! them (a pressure, a flux, a seal). Data the network's build and the flow read.

use crate::error::{Error, Result};
use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// What a boundary region does to the pores whose centres lie in it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum BoundaryKind {
    /// The pores hold this (gauge) pressure (Pa): a reservoir.
    Pressure(f64),
    /// This volumetric rate (m³/s, at ρ0) enters the region, shared by pore volume;
    /// negative draws fluid out.
    Flux(f64),
    /// No source (the default everywhere): a region listed later can seal what an earlier
    /// one opened.
    Impermeable,
}

/// Which pores a boundary condition holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PoreRegion {
    /// The pores whose centre lies in the box (corners `lo`, `hi`).
    Box { lo: Vec3, hi: Vec3 },
    /// The pores with one of these elements at a corner of one of their tetrahedra (a group
    /// of the hull: the pores it bounds).
    Elements(Vec<u32>),
    /// The one pore whose centre is nearest the point (an injection well).
    Point(Vec3),
    /// The pores whose centre lies within `radius` of the line through `center` along `axis`
    /// (a unit vector): a borehole's pores, whatever its direction.
    Cylinder { center: Vec3, axis: Vec3, radius: f64 },
}

impl PoreRegion {
    /// A borehole along `axis` (any length, not zero) through `center`, of this radius (> 0).
    pub fn cylinder(center: Vec3, axis: Vec3, radius: f64) -> Result<Self> {
        let n = axis.norm();
        if !(n > 0.0 && n.is_finite() && center.iter().all(|x| x.is_finite())) {
            return Err(Error::InvalidScene(format!(
                "a cylinder of pores needs a finite center and a finite, non-zero axis (got center {center:?}, axis {axis:?})"
            )));
        }
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(Error::param("pore cylinder radius", radius, "must be a finite number above 0 (m)"));
        }
        Ok(PoreRegion::Cylinder { center, axis: axis / n, radius })
    }

    /// Whether a pore centred at `c` lies in a region given by a shape (a box or a cylinder);
    /// `None` for regions given by elements or a nearest point.
    pub(crate) fn contains(&self, c: &Vec3) -> Option<bool> {
        match self {
            PoreRegion::Box { lo, hi } => Some((0..3).all(|d| c[d] >= lo[d] && c[d] <= hi[d])),
            PoreRegion::Cylinder { center, axis, radius } => {
                let r = c - center;
                Some((r - axis * r.dot(axis)).norm_squared() <= radius * radius)
            }
            PoreRegion::Elements(_) | PoreRegion::Point(_) => None,
        }
    }
}

/// A region of pores with a boundary condition. Regions apply in order; the last that holds a
/// pore wins. Pores in no region are closed: the hull of the network is impermeable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoreBoundary {
    pub region: PoreRegion,
    pub kind: BoundaryKind,
    /// With the heat field on: the temperature (K) of the fluid the region supplies — a
    /// fixed-pressure region's pores are held at it (a reservoir), a flux region injects at
    /// it. `None`: fluid enters at the pore's own temperature (a drain). Not in the
    /// boundary's own encoding: checkpoints carry it in the pore heat section, so files
    /// written before it existed still load.
    #[serde(skip)]
    pub temperature: Option<f64>,
}

impl PoreBoundary {
    /// The pores whose centres lie in the box `lo`..`hi`.
    pub fn boxed(lo: Vec3, hi: Vec3, kind: BoundaryKind) -> Self {
        PoreBoundary { region: PoreRegion::Box { lo, hi }, kind, temperature: None }
    }

    /// The same region and kind, supplying fluid at `temperature` (K).
    pub fn at_temperature(self, temperature: f64) -> Self {
        PoreBoundary { temperature: Some(temperature), ..self }
    }
}
