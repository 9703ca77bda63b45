//! Applied loads: the external force and torque a script put on each element (`d.apply_force`,
//! `d.apply_torque`), constant until changed, added before integration; their work is booked in
//! the energy account. An optional force stage: its lanes exist only while some element carries
//! a load.
//!
//! The effect's folder: the loads and their work account (`lanes.rs`), the CPU pass (`cpu.rs`)
//! and the GPU kernel (`gpu.rs`, with `shaders/applied_loads.wgsl`).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod lanes;

use crate::model::Model;

/// What the `applied_loads` stage has to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AppliedLoadsPlan {
    /// Elements with a force or a torque.
    pub loaded: usize,
    /// Some element carries a torque (the stage then writes the torque lane too).
    pub torques: bool,
}

impl AppliedLoadsPlan {
    /// The stage, when some element of `m` carries a load.
    pub fn of(m: &Model) -> Option<Self> {
        let a = &m.particles.applied;
        if !a.allocated(m.len()) {
            return None;
        }
        let loaded = a.loaded();
        (loaded > 0).then(|| AppliedLoadsPlan { loaded, torques: a.has_torque() })
    }
}

impl AppliedLoadsPlan {
    /// The stage in the plan's words.
    pub fn words(&self) -> String {
        let what = if self.torques { "forces and torques" } else { "forces" };
        format!("applied loads({what} on {} element(s), work booked)", self.loaded)
    }
}
