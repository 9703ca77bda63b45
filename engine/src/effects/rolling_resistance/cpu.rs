//! The `rolling_resistance` stage on the CPU: each particle walks its own neighbour row and its
//! walls, and adds to its torque the rolling resistance of each contact
//! (effects/rolling_resistance/physics.rs) from its own side. The contact's geometry and elastic normal
//! force are recomputed from the positions, as the contact stage found them this step, so the
//! stage reads no scratch of the core's; each pair is evaluated from both rows, with exactly
//! opposite inputs, so the two torques (and the epsd springs) are exactly opposite. No atomics:
//! deterministic whatever the thread count. Runs after `wall_forces` (and `parallel_bond`),
//! before `integrate`.
//!
//! The work the torques take from the relative rotation, −M·ω_rel·dt per contact, goes into the
//! heat ledger's friction lane (rolling friction), half to each element of a pair (each row
//! computes the whole pair's: M and ω_rel both flip), all of it to the element at a wall. GPU twin: `effects/rolling_resistance/gpu.rs`
//! (shaders/rolling_resistance.wgsl; cdt only).

use crate::backend::cpu::blocks::{for_blocks, Rows, Strided};
use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::rolling_resistance::physics::{
    cdt_torque, epsd_torque, pair_inertia, RollingContact, RollingModel, RollingResistance,
};
use crate::model::Model;
use crate::physics::contact_law::{NormalLaw, TangentialLaw};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::state::contacts::Contacts;

/// The stage's pass (`backend::cpu::stage::Build`).
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, s: &StageInput| {
        rolling_resistance(m, s.plan);
        Ok(Booked::default())
    })
}

/// Adds this step's rolling resistance torques to the particles' (overwritten by
/// `contact_forces` earlier in the step). The rotation lanes must exist (a plan with the stage
/// rotates); epsd's springs are allocated here on first use.
pub fn rolling_resistance(m: &mut Model, plan: &StepPlan) {
    let Some(r) = plan.rolling else { return };
    let epsd = r.model == RollingModel::Epsd;
    crate::with_laws!(plan, rolling_loop[epsd](m, plan, &r))
}

/// Sizes epsd's springs for the model's rows and walls (zeros where they do not fit: a new
/// model, or rows the GPU built).
pub fn fit_springs(m: &mut Model) {
    let c = &mut m.contacts;
    if c.rolling.len() != c.other.len() {
        c.rolling = vec![Vec3::zeros(); c.other.len()];
    }
    let walls = m.len() * m.walls.len();
    if m.wall_rolling.len() != walls {
        m.wall_rolling = vec![Vec3::zeros(); walls];
    }
}

fn rolling_loop<N: NormalLaw, T: TangentialLaw, const EPSD: bool>(
    m: &mut Model,
    plan: &StepPlan,
    r: &RollingResistance,
) {
    if EPSD {
        fit_springs(m);
    }
    let dt = m.clock.dt;
    let n = m.len();
    let nw = m.walls.len();
    let sep = m.separations();
    let Model { particles: p, contacts, walls, wall_rolling, .. } = m;
    let Contacts { row_start, other, wall_near, rolling, .. } = contacts;
    if row_start.len() != n + 1 {
        return;
    }
    let (pos, radius, mass, material) = (&p.pos[..], &p.radius[..], &p.mass[..], &p.material[..]);
    let rot = p.rotation.as_mut().expect("a plan with rolling resistance allocates the rotation lanes");
    let (ang_vel, torque) = (&rot.ang_vel[..], &mut rot.torque[..]);
    let friction = plan.heat.friction.then_some(&mut p.heat.friction[..]);
    let (row_start, other, near, walls) = (&row_start[..], &other[..], &wall_near[..], &walls[..]);
    let inertia = |i: usize| 0.4 * mass[i] * radius[i] * radius[i];
    let wall_springs = Some(Strided { items: &mut wall_rolling[..], stride: nw }).filter(|_| EPSD && nw > 0);
    let pair_springs = Some(&mut rolling[..]).filter(|_| EPSD);
    for_blocks(0..n, Rows::Csr(row_start), (torque, wall_springs, friction), pair_springs, &|range,
                                                                                             (
        torque,
        mut wall_springs,
        mut friction,
    ): (
        &mut [Vec3],
        Option<Strided<Vec3>>,
        Option<&mut [f64]>,
    ),
                                                                                             mut springs: Option<
        &mut [Vec3],
    >| {
        let base = row_start[range.start] as usize;
        for i in range.clone() {
            let li = i - range.start;
            let (xi, ri, wi, ii, mati) = (pos[i], radius[i], ang_vel[i], inertia(i), material[i]);
            let mut t = Vec3::zeros();
            // The work the torques take, whole pairs and whole wall contacts.
            let (mut pair_heat, mut wall_heat) = (0.0, 0.0);
            for e in row_start[i] as usize..row_start[i + 1] as usize {
                let j = other[e] as usize;
                // Through the nearest image in a periodic cell.
                let d = sep.between(pos, i, j);
                let rj = radius[j];
                let touch = ri + rj;
                let dist2 = d.norm_squared();
                let spring = springs.as_deref_mut().map(|s| &mut s[e - base]);
                if dist2 >= touch * touch {
                    // Apart: the rolling spring lets go with the contact.
                    if let Some(s) = spring {
                        *s = Vec3::zeros();
                    }
                    continue;
                }
                let dist = dist2.sqrt();
                let overlap = touch - dist;
                let r_eff = ri * rj / touch;
                let pp = plan.pair(mati, material[j]);
                let c = RollingContact {
                    n: d / dist,
                    w_rel: wi - ang_vel[j],
                    r_eff,
                    normal_force: N::force(pp, r_eff, overlap),
                    inertia: pair_inertia(ii, inertia(j)),
                };
                let m = match spring {
                    Some(s) => epsd_torque(r, &c, T::stiffness(pp, r_eff, overlap), s, dt),
                    None => cdt_torque(r.mu_r, &c, dt),
                };
                t += m;
                pair_heat -= m.dot(&c.w_rel) * dt;
            }
            let mut bits = near.get(i).copied().unwrap_or(0);
            while bits != 0 {
                let w = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (inward, gap) = walls[w].normal_and_distance(&xi);
                let overlap = ri - gap;
                let spring = wall_springs.as_mut().map(|s| &mut s.items[li * nw + w]);
                if overlap <= 0.0 {
                    if let Some(s) = spring {
                        *s = Vec3::zeros();
                    }
                    continue;
                }
                let pp = plan.wall_pair(w, mati);
                let c = RollingContact {
                    n: -inward,
                    w_rel: wi,
                    r_eff: ri,
                    normal_force: N::force(pp, ri, overlap),
                    inertia: ii,
                };
                let m = match spring {
                    Some(s) => epsd_torque(r, &c, T::stiffness(pp, ri, overlap), s, dt),
                    None => cdt_torque(r.mu_r, &c, dt),
                };
                t += m;
                wall_heat -= m.dot(&c.w_rel) * dt;
            }
            torque[li] += t;
            if let Some(h) = friction.as_deref_mut() {
                h[li] += 0.5 * pair_heat + wall_heat;
            }
        }
    })
}
