//! The `contact_forces`, `wall_forces` and `integrate` stages of an unobserved step in two passes
//! instead of four: the contacts' pair pass (contact_forces.rs), then one pass in which each
//! particle gathers its row, meets the walls in its mask and moves (integrate.rs). The new
//! pair states stay in the pair records until something reads the rows (`sync_rows`).
//!
//! Once the pair pass is done, what is left of the step reads nothing of any other particle
//! (the pair results are in the scratch), so a particle can finish its step as soon as it has
//! summed its forces, while its lanes are still in cache. Each of the three stages runs the
//! same per-particle code, in the same order, as its own pass does, so a fused step gives the
//! separate passes' numbers bit for bit. Observed steps keep the separate passes, because
//! their energies are taken between the forces and the move.

use super::blocks::{for_blocks, Rows, Strided};
use super::contact_forces::{gather_row, pair_pass, Breaks, PairScratch};
use super::integrate::{advance, spin, Motion, Observed, Translation};
use super::prefetch::prefetch;
use super::wall_forces::{particle_walls, store_loads, Body, ParticleOut, WallLoads};
use crate::effects::heat_ledger::cpu::HeatLanes;
use crate::model::Model;
use crate::physics::contact_law::{NormalLaw, TangentialLaw};
use crate::plan::StepPlan;

/// Computes this step's contact and wall forces and advances the particles by the step, as
/// `compute_contact_forces`, `compute_wall_forces` and an unobserved `integrate` do in turn.
/// The rows must carry pair ids and the rotation lanes must exist when the plan rotates.
pub fn forces_and_motion(m: &mut Model, plan: &StepPlan, scratch: &mut PairScratch, damping_c: &[f64]) -> Breaks {
    let rot = plan.rotation && m.particles.rotation.is_some();
    let (damp, local) = (!damping_c.is_empty(), m.settings.local_damping > 0.0);
    crate::with_laws!(plan, run[plan.dashpot, rot, damp, local](m, plan, scratch, damping_c))
}

fn run<N, T, const DASHPOT: bool, const ROT: bool, const DAMP: bool, const LOCAL: bool>(
    m: &mut Model,
    plan: &StepPlan,
    scratch: &mut PairScratch,
    damping_c: &[f64],
) -> Breaks
where
    N: NormalLaw,
    T: TangentialLaw,
{
    debug_assert!(m.contacts.has_pair_ids(), "rows without pair ids: rebuild them first");
    scratch.fit::<T>(m.contacts.pair_count());
    let breaks = pair_pass::<N, T, DASHPOT, ROT>(m, plan, scratch);
    let loads = finish::<N, T, DASHPOT, ROT, DAMP, LOCAL>(m, plan, scratch, damping_c);
    // The new pair states stay in the records, the rows' copies behind (contact_forces.rs,
    // `PairScratch`): the next pair pass reads them there.
    scratch.rows_behind = true;
    store_loads(&mut m.walls, &loads);
    breaks
}

/// How many particles ahead the pass asks for wall states.
const WALL_AHEAD: usize = 8;

/// The pass after the pair pass: gather, walls, integration, particle by particle.
fn finish<N, T, const DASHPOT: bool, const ROT: bool, const DAMP: bool, const LOCAL: bool>(
    m: &mut Model,
    plan: &StepPlan,
    scratch: &PairScratch,
    damping_c: &[f64],
) -> WallLoads
where
    N: NormalLaw,
    T: TangentialLaw,
{
    let k = Motion::of(m);
    let nw = m.walls.len();
    let Model { particles: p, contacts: c, wall_contacts, walls, .. } = m;
    let (row_start, pair_start, pair, near) = (&c.row_start[..], &c.pair_start[..], &c.pair[..], &c.wall_near[..]);
    debug_assert_eq!(near.len(), p.pos.len(), "wall mask out of date: rebuild the rows first");
    let (radius, mass, material, fixed) = (&p.radius[..], &p.mass[..], &p.material[..], &p.fixed[..]);
    let (spin_lanes, torque) = match &mut p.rotation {
        Some(r) if ROT => (Some((&mut r.ang_vel[..], &mut r.angle[..])), Some(&mut r.torque[..])),
        _ => (None, None),
    };
    let loads_lanes = (&mut p.force[..], torque, HeatLanes::of(&mut p.heat, &plan.heat));
    let motion_lanes =
        (&mut p.pos[..], &mut p.vel[..], spin_lanes, Strided { items: &mut wall_contacts[..], stride: nw });
    let walls = &walls[..];
    for_blocks(
        0..radius.len(),
        Rows::None,
        (loads_lanes, motion_lanes),
        (),
        &|range, ((force, mut torque, mut heat), (pos, vel, mut spin_lanes, wall_state)), ()| {
            let mut loads = WallLoads::default();
            let mut unobserved = Observed::default();
            for i in range.clone() {
                let li = i - range.start;
                let ri = radius[i];
                // The wall states of the particles along a wall are far apart and fall out of
                // the cache between steps: ask for the next ones while this particle works.
                let ahead = li + WALL_AHEAD;
                if ahead < range.len() && near[i + WALL_AHEAD] != 0 {
                    let w = near[i + WALL_AHEAD].trailing_zeros() as usize;
                    prefetch(&wall_state.items[ahead * nw + w]);
                }
                // contact_forces: the row's forces.
                let (start, end) = (row_start[i] as usize, row_start[i + 1] as usize);
                let own = end - (pair_start[i + 1] - pair_start[i]) as usize;
                let row = gather_row::<T, ROT>(scratch, &pair[start..end], own - start, ri, None);
                let (mut f, mut t) = (row.force, row.torque);
                heat.book_row(li, &row.heat);
                // wall_forces: the walls in reach (most particles have none).
                let wall_st = &mut wall_state.items[li * nw..(li + 1) * nw];
                #[cfg(debug_assertions)]
                super::wall_forces::check_mask(walls, i, near[i], &pos[li], ri, wall_st);
                if near[i] != 0 {
                    let body = Body {
                        pos: pos[li],
                        radius: ri,
                        vel: vel[li],
                        mass: mass[i],
                        ang_vel: spin_lanes.as_ref().map(|(a, _)| a[li]),
                        material: material[i],
                    };
                    let mut out = ParticleOut {
                        force: &mut f,
                        torque: if ROT { Some(&mut t) } else { None },
                        heat: heat.walls_at(li),
                    };
                    particle_walls::<N, T, DASHPOT>(walls, plan, k.dt, near[i], &body, wall_st, &mut out, &mut loads);
                }
                force[li] = f;
                // integrate: body forces, damping and the move.
                let c = if DAMP { damping_c[i] } else { 0.0 };
                let b = Translation { mass: mass[i], damping_c: c, fixed: fixed[i], force: f };
                advance::<DAMP, LOCAL, false>(&k, &b, &mut pos[li], &mut vel[li], heat.damping_at(li), &mut unobserved);
                if let (Some(tq), Some((w, angle))) = (torque.as_deref_mut(), spin_lanes.as_mut()) {
                    tq[li] = t;
                    spin::<DAMP, false>(
                        k.dt,
                        mass[i],
                        ri,
                        c,
                        fixed[i],
                        t,
                        &mut w[li],
                        &mut angle[li],
                        heat.damping_at(li),
                        &mut unobserved,
                    );
                }
            }
            loads
        },
    )
}
