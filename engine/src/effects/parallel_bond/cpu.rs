//! The `parallel_bond` stage on the CPU: each particle walks its row of parallel bonds, updates
//! every bond in the bond's canonical orientation (lower id first: both rows compute the same
//! numbers and take the same breaking decision), stores the new state in its own row entry and
//! adds its side's force and torque to what the contact and wall stages summed. No atomics,
//! no scratch: each bond is evaluated twice, once per row, which keeps each particle's sum in
//! its own row order. Runs after `wall_forces` and before `integrate`. GPU twin:
//! `effects/parallel_bond/gpu.rs` (shaders/parallel_bond.wgsl).

use crate::backend::cpu::blocks::{for_blocks, Rows};
use crate::backend::cpu::contact_forces::Breaks;
use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::parallel_bond::physics::{update, BondState, Ends};
use crate::model::Model;
use crate::physics::Vec3;
use crate::plan::StepPlan;

/// The stage's pass (`backend::cpu::stage::Build`): the bonds that broke go to the backend.
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, s: &StageInput| Ok(Booked { breaks: parallel_bond(m, s.plan), ..Booked::default() }))
}

/// Adds the parallel bonds' forces and torques of this step to the particles' (overwritten by
/// `contact_forces` earlier in the step), books the energy a breaking bond releases into the
/// ledger's breakage lane when the plan keeps it, and returns the bonds that broke (once each,
/// from the lower id). The rotation lanes must exist (a plan with the stage rotates).
pub fn parallel_bond(m: &mut Model, plan: &StepPlan) -> Breaks {
    let Some(params) = plan.parallel_bond else { return Breaks::default() };
    let dt = m.clock.dt;
    let n = m.particles.len();
    m.parallel_bonds.fit(n);
    let sep = m.separations();
    let Model { particles: p, parallel_bonds: b, .. } = m;
    if b.row_start.is_empty() {
        return Breaks::default();
    }
    let (pos, vel, radius) = (&p.pos[..], &p.vel[..], &p.radius[..]);
    let rot = p.rotation.as_mut().expect("a plan with parallel bonds allocates the rotation lanes");
    let (ang_vel, torque) = (&rot.ang_vel[..], &mut rot.torque[..]);
    let breakage = if plan.heat.breakage { Some(&mut p.heat.breakage[..]) } else { None };
    let (row_start, other) = (&b.row_start[..], &b.other[..]);
    for_blocks(
        0..n,
        Rows::Csr(row_start),
        (&mut p.force[..], torque, breakage),
        &mut b.state[..],
        &|range, (force, torque, mut breakage), state: &mut [BondState]| {
            let base = row_start[range.start] as usize;
            let mut breaks = Breaks::default();
            for i in range.clone() {
                let li = i - range.start;
                let (mut f, mut t, mut heat) = (Vec3::zeros(), Vec3::zeros(), 0.0);
                for e in row_start[i] as usize..row_start[i + 1] as usize {
                    let st = &mut state[e - base];
                    if !st.intact() {
                        continue;
                    }
                    let j = other[e] as usize;
                    let (lo, hi) = if i < j { (i, j) } else { (j, i) };
                    // In a periodic cell the bond joins lo to hi's nearest image (moving with
                    // the image's velocity under Lees–Edwards shear).
                    let (far, far_vel) = match sep.periodic() {
                        true => {
                            let (d, image_vx) = sep.between_sliding(pos, lo, hi);
                            (pos[lo] + d, vel[hi] + Vec3::x() * image_vx)
                        }
                        false => (pos[hi], vel[hi]),
                    };
                    let ends = Ends {
                        pos: [pos[lo], far],
                        vel: [vel[lo], far_vel],
                        ang_vel: [ang_vel[lo], ang_vel[hi]],
                        radius: [radius[lo], radius[hi]],
                    };
                    let load = update(&params, &ends, st, dt);
                    let side = usize::from(i != lo);
                    f += load.force[side];
                    t += load.torque[side];
                    if let Some((kind, energy)) = load.broke {
                        // Each end books half of what the bond held; the lower id logs it.
                        heat += 0.5 * energy;
                        if side == 0 {
                            breaks.0.push((lo as u32, hi as u32, kind));
                        }
                    }
                }
                force[li] += f;
                torque[li] += t;
                if let Some(l) = breakage.as_deref_mut() {
                    l[li] += heat;
                }
            }
            breaks
        },
    )
}
