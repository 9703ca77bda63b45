//! Rolling resistance (LIGGGHTS' rolling friction; docs/rolling-resistance.md): a torque against
//! each contact's relative rolling, capped at μ_r·R_eff·F_n, by the cdt (constant directional
//! torque) or the epsd (elastic-plastic spring-dashpot) model. An optional force stage: a scene
//! without a rolling resistance (μ_r = 0) has no pass and no pipeline, and only epsd keeps lanes
//! (a rolling spring per row entry and per particle and wall, in the contact rows).
//!
//! The effect's folder: the laws (`physics.rs`, whose [`RollingResistance`](physics::RollingResistance)
//! is the scene's setting), the CPU pass (`cpu.rs`) and the GPU kernel (`gpu.rs`, with
//! `shaders/rolling_resistance.wgsl`).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod physics;

use physics::{RollingModel, RollingResistance};

impl RollingResistance {
    /// The stage in the plan's words.
    pub fn words(&self) -> String {
        match self.model {
            RollingModel::Cdt => format!("rolling resistance(cdt, μ_r {})", self.mu_r),
            RollingModel::Epsd => {
                format!("rolling resistance(epsd, μ_r {}, k_r = k_t·R_eff², η_r {})", self.mu_r, self.damping)
            }
        }
    }
}
