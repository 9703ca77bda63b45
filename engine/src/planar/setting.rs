//! A 2D model's setting, apart from the model that holds it.

use crate::state::particles::dof;
use serde::{Deserialize, Serialize};

/// What a 2D model holds for every element: y, and spin about x and z.
pub const HELD: u8 = dof::Y | dof::RX | dof::RZ;

/// A 2D model's setting: the plate's thickness (m), the length its stresses and volumes take
/// for y.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Planar {
    pub thickness: f64,
}
