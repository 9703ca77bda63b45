//! The water table's settings (the `buoyancy` stage), held by the model's
//! [`Settings`](crate::model::Settings); the model-level calls are in `effects/conduction/mod.rs`.

use serde::{Deserialize, Serialize};

/// The water table (the `buoyancy` stage), off until a level is set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WaterTable {
    /// Height (z) of the free surface (m); `None`: no water.
    pub level: Option<f64>,
    /// Fluid density ρ_f (kg/m³).
    pub density: f64,
    /// Dynamic viscosity μ (Pa·s) of a linear (Stokes) drag −6π·μ·r·v on the submerged part of
    /// an element; 0 = no drag.
    pub viscosity: f64,
}

impl Default for WaterTable {
    fn default() -> Self {
        WaterTable { level: None, density: 1000.0, viscosity: 0.0 }
    }
}
