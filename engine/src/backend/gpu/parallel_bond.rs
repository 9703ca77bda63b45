//! The `parallel_bond` stage on the GPU (shaders/parallel_bond.wgsl). CPU twin:
//! `backend/cpu/parallel_bond.rs`. Until the twin is in, a plan with the stage is refused
//! here with a clear message rather than stepped without its bonds.

use crate::error::{Error, Result};
use crate::plan::{Stage, StepPlan};

/// Refuses a plan this backend cannot step.
pub fn check_plan(plan: &StepPlan) -> Result<()> {
    if plan.has(Stage::ParallelBond) {
        return Err(Error::InvalidScene(
            "parallel bonds are simulated on the CPU backend only in this build: run with --backend cpu".into(),
        ));
    }
    Ok(())
}
