//! Heat conduction's settings (the `conduction` stage): what a scene chooses, held by the
//! model's [`Settings`](crate::model::Settings); the model-level calls are in `effects/conduction/mod.rs`.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A material's thermal properties.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThermalProps {
    /// Thermal conductivity k (W/(m·K)) of the element's solid.
    pub conductivity: f64,
    /// Specific heat c (J/(kg·K)): an element's heat capacity is C = m·c.
    pub specific_heat: f64,
    /// Linear thermal expansion coefficient α (1/K): r = r0·(1 + α·(T − T0)).
    pub expansion: f64,
}

impl Default for ThermalProps {
    fn default() -> Self {
        // No conduction and no expansion until the script says so; a capacity of zero is
        // refused before a run (it would make any heat an infinite temperature).
        ThermalProps { conductivity: 0.0, specific_heat: 0.0, expansion: 0.0 }
    }
}

impl ThermalProps {
    pub fn validate(&self, what: &str) -> Result<()> {
        for (name, v) in
            [("conductivity", self.conductivity), ("specific_heat", self.specific_heat), ("expansion", self.expansion)]
        {
            if !v.is_finite() || (name != "expansion" && v < 0.0) {
                return Err(Error::InvalidScene(format!(
                    "{what}: `{name}` = {v} must be a finite number{}",
                    if name == "expansion" { "" } else { " ≥ 0" }
                )));
            }
        }
        Ok(())
    }
}

/// Heat conduction between elements (the `conduction` stage), off by default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeatSettings {
    pub enabled: bool,
    /// Reference temperature T0: elements start at it, and expand from it.
    pub reference: f64,
    /// The field step is `every` mechanical steps: conduction runs after every `every`-th step
    /// with Δt_f = every·dt (the temperature changes far more slowly than the contacts).
    pub every: u32,
    /// Forward-Euler sub-steps of each field step, each Δt_f/substeps long: the way to keep a
    /// long field step under the stability limit C/ΣH.
    pub substeps: u32,
    /// Feed the heat the ledger books (damping, contact damping, friction, breakage; not wall
    /// work) into the temperature of the element it belongs to.
    pub dissipation: bool,
    /// A bond's contact radius as a fraction of the smaller element's radius: bonded elements
    /// conduct through this neck even where they barely touch.
    pub bond_radius: f64,
    /// Thermal properties by material name (a material not named has none).
    pub materials: BTreeMap<String, ThermalProps>,
}

impl Default for HeatSettings {
    fn default() -> Self {
        HeatSettings {
            enabled: false,
            reference: 293.15,
            every: 1,
            substeps: 1,
            dissipation: false,
            bond_radius: 0.5,
            materials: BTreeMap::new(),
        }
    }
}
