//! The `pore_flow` stage on the CPU, a force stage between `wall_forces` (and
//! `parallel_bond`) and `integrate`: the pore network follows the elements (rebuilt, its fluid
//! carried over, when an element has drifted far or the element count changed), the fluid
//! advances by dt in explicit sub-steps under its stable flow step (the guard's error, naming
//! the pore, when that needs more than the fluid's `max_substeps`; the state is then left as
//! it was, never NaN), and each element adds the pressure of the pores at its corners to its
//! own force ([`crate::effects::pore_flow::pressure_forces`]: a per-element gather, no atomics). With the
//! heat field on (the plan's `thermal`), each pore's fluid has a temperature, carried by the
//! flow and exchanged with the elements at its corners after the flow's sub-steps
//! ([`crate::effects::pore_flow::fluid_temperature`], run by `effects/pore_flow/cpu/heat.rs`). GPU twin:
//! `effects/pore_flow/gpu/mod.rs` (shaders/pore_flow.wgsl), with `effects/pore_flow/gpu/heat.rs`
//! (shaders/pore_heat.wgsl) for the fluid's temperature.

pub mod heat;

use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::pore_flow::PoreFlowPlan;
use crate::error::Result;
use crate::model::Model;
use crate::plan::StepPlan;
use heat as pore_heat;

/// The stage's pass (`backend::cpu::stage::Build`): a guard error ends the run at the end of
/// the step that raised it.
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, s: &StageInput| {
        if let Some(p) = &s.plan.pore_flow {
            pore_flow(m, p)?;
        }
        Ok(Booked::default())
    })
}

/// Runs the stage on the model's pore network (a no-op when it has none).
pub fn pore_flow(m: &mut Model, plan: &PoreFlowPlan) -> Result<()> {
    let Some(mut f) = m.pores.take() else { return Ok(()) };
    let mut result = Ok(());
    if plan.thermal {
        pore_heat::fit(m, &mut f);
    }
    if f.network.tri.points.len() != m.len() {
        result = f.rebuild(m);
    }
    if result.is_ok() {
        result = f.advance(m, m.clock.dt);
    }
    if result.is_ok() && plan.thermal {
        result = pore_heat::exchange(m, &mut f);
    }
    if result.is_ok() {
        f.add_forces(&m.particles.pos, &mut m.particles.force);
    }
    m.pores = Some(f);
    result
}
