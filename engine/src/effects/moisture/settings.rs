//! Moisture's settings (the `moisture` stage), part of its state in the model (`state.rs`);
//! the model-level calls are in this folder's `mod.rs`.

use crate::effects::moisture::physics::Table;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Moisture diffusion between elements (the `moisture` stage), off by default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MoistureSettings {
    pub enabled: bool,
    /// The water content elements start at when moisture is switched on (and new elements).
    pub initial: f64,
    /// The field step is `every` mechanical steps (Δt_f = every·dt).
    pub every: u32,
    /// Forward-Euler sub-steps of each field step.
    pub substeps: u32,
    /// A bond's neck radius as a fraction of the smaller element's radius (as heat's).
    pub bond_radius: f64,
    /// Moisture diffusivity α_w (kg/(m²·s)) by material name (a material not named has none).
    pub materials: BTreeMap<String, f64>,
    /// Drying shrinkage: the radius factor f_r(ω), r = r0·f_r(ω).
    pub radius_table: Option<Table>,
    /// A bond's share s(ω) ∈ (0, 1] of its material pair's strength, at the pair's mean ω.
    pub strength_table: Option<Table>,
}

impl Default for MoistureSettings {
    fn default() -> Self {
        MoistureSettings {
            enabled: false,
            initial: 0.0,
            every: 1,
            substeps: 1,
            bond_radius: 0.5,
            materials: BTreeMap::new(),
            radius_table: None,
            strength_table: None,
        }
    }
}

impl MoistureSettings {
    /// The diffusivity of an element of `material`: its own, or that of the material it was
    /// cloned from (`base`), or none.
    pub fn diffusivity(&self, material: &str, base: &str) -> f64 {
        self.materials.get(material).or_else(|| self.materials.get(base)).copied().unwrap_or(0.0)
    }
}
