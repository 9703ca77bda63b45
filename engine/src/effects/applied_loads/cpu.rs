//! The `applied_loads` stage on the CPU, a force stage after `wall_forces`, `parallel_bond`,
//! `rolling_resistance` and `pore_flow` and before `buoyancy` (whose drag reads the sum of the
//! others) and `integrate`: each loaded element adds its applied force to its force lane and, when
//! the plan has torques, its applied torque to its torque lane. Each element writes only its own
//! lanes: no atomics. Killed elements feel nothing (they are out of the model, kill.rs).
//!
//! Because the loads are in the lanes before `integrate`, local damping and the status'
//! unbalanced force see them, as they see buoyancy. Their work is not booked here: it is a
//! potential of the positions and angles (effects/applied_loads/lanes.rs), read with the energies.

use crate::backend::cpu::blocks::{for_blocks, Rows};
use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::applied_loads::AppliedLoadsPlan;
use crate::model::Model;
use crate::plan::StepPlan;
use crate::state::particles::dof;

/// The stage's pass (`backend::cpu::stage::Build`).
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, s: &StageInput| {
        if let Some(a) = &s.plan.applied_loads {
            applied_loads(m, a);
        }
        Ok(Booked::default())
    })
}

/// Adds each element's applied force (and torque) to this step's force (and torque) lane.
pub fn applied_loads(m: &mut Model, plan: &AppliedLoadsPlan) {
    let p = &mut m.particles;
    let (fixed, loads) = (&p.fixed, &p.applied);
    let torque = match &mut p.rotation {
        Some(r) if plan.torques => Some(&mut r.torque[..]),
        _ => None,
    };
    for_blocks(0..fixed.len(), Rows::None, (&mut p.force[..], torque), (), &|range, (force, mut torque), ()| {
        for i in range.clone() {
            if fixed[i] & dof::KILLED != 0 {
                continue;
            }
            let li = i - range.start;
            force[li] += loads.force[i];
            if let Some(t) = torque.as_deref_mut() {
                t[li] += loads.torque[i];
            }
        }
    });
}
