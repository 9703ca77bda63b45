//! The `confining_pressure` stage on the CPU, a force stage after `applied_loads` and before
//! `buoyancy` (whose drag reads the others' sum) and `integrate`: the membrane's cells placed
//! between the platens where they stand this step, each cell's outermost grain found (serially, in
//! id order: deterministic), and each such grain pushed towards the axis with the pressure times
//! its patch and the patches of the empty cells it covers (`physics.rs`). A grain is in one cell, so each grain's force lane is written once.
//! Killed elements feel nothing. CPU twin of `gpu.rs`.

use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::confining_pressure::physics::{picks, NONE};
use crate::effects::confining_pressure::ConfiningPlan;
use crate::model::Model;
use crate::plan::StepPlan;

/// The stage's pass (`backend::cpu::stage::Build`).
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, s: &StageInput| {
        if let Some(c) = &s.plan.confining {
            confining_pressure(m, c);
        }
        Ok(Booked::default())
    })
}

/// Adds the membrane's load to the force lane of each grain it touches.
pub fn confining_pressure(m: &mut Model, plan: &ConfiningPlan) {
    let cells = plan.cells(&m.walls);
    let p = &mut m.particles;
    let (best, shares) = picks(&cells, p);
    for (&(i, _), &k) in best.iter().zip(&shares).filter(|(b, _)| b.0 != NONE) {
        let i = i as usize;
        let place = cells.place(&p.pos[i], p.radius[i]);
        p.force[i] += cells.load(plan.pressure, &place, k);
    }
}
