//! The water table's buoyancy (paper 003 §3.3): −ρ_f·V_sub·g on the submerged part of every
//! element below the level, with Stokes drag, a force stage added before integration so local
//! damping sees it. A scene without a level has no pass and no pipeline for it; it keeps no
//! lanes of its own. The submerged volume is in `physics.rs`, the level and the fluid in
//! `settings.rs` (part of [`crate::model::Settings`]), the passes in `cpu.rs` and `gpu.rs`.

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod physics;
pub mod settings;

pub use crate::effects::buoyancy::settings::WaterTable;
use crate::model::Model;

/// What a plan with the `buoyancy` stage runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuoyancyPlan {
    pub level: f64,
    pub density: f64,
    pub viscosity: f64,
}

impl BuoyancyPlan {
    pub fn of(m: &Model) -> Option<Self> {
        let w = &m.settings.water;
        w.level.map(|level| BuoyancyPlan { level, density: w.density, viscosity: w.viscosity })
    }
}

impl BuoyancyPlan {
    /// The stage in the plan's words.
    pub fn words(&self) -> String {
        let drag = if self.viscosity > 0.0 {
            format!(", stokes drag μ = {:.3e} Pa·s", self.viscosity)
        } else {
            String::new()
        };
        format!("buoyancy(water level z = {} m, ρ_f = {} kg/m³{drag})", self.level, self.density)
    }
}

impl crate::model::Model {
    /// Puts the water table at `level` (m), or removes it (`None`). Moving the table does work
    /// on the elements where they stand (the energy account's body work), booked before and
    /// after the change.
    pub fn set_water_level(&mut self, level: Option<f64>) {
        self.book_body_work();
        self.settings.water.level = level;
        self.book_body_work();
    }
}
