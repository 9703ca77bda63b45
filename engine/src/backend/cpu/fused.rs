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

use super::blocks::{for_blocks, for_nodes, node_ends, Rows, Strided};
use super::contact_forces::{gather_row, Breaks, Kinematics, PairPass, PairScratch, SharedRecords};
use super::heat::HeatLanes;
use super::integrate::{advance, spin, Motion, Observed, Translation};
use super::prefetch::prefetch;
use super::wall_forces::{particle_walls, store_loads, Body, ParticleOut, WallLoads};
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
    let (breaks, loads) = block_local::<N, T, DASHPOT, ROT, DAMP, LOCAL>(m, plan, scratch, damping_c);
    // The new pair states stay in the records, the rows' copies behind (contact_forces.rs,
    // `PairScratch`): the next pair pass reads them there.
    scratch.rows_behind = true;
    store_loads(&mut m.walls, &loads);
    breaks
}

/// How many particles ahead the pass asks for wall states.
const WALL_AHEAD: usize = 8;

/// Blocks of particles per node of the block-local pass: a node's pair records, particle lanes
/// and rows (~130 kB a block in the standard scene) stay in a core's 2 MB L2 between its pairs
/// and its gather, and the larger the node, the fewer pairs cross between nodes.
const NODE_BLOCKS: usize = 8;

/// The step's pairs and the pass after them, node by node of the blocks' tree: first every
/// pair whose ends are in different nodes (in parallel, each from its lower id), then, for
/// each node in parallel, the pairs inside it and, right after, its particles' gather, walls
/// and integration, while the node's records are still in cache. A pair is still evaluated
/// before either end moves, from the same inputs, and every sum runs in the same order: the
/// numbers are those of a whole pair pass followed by the whole gather.
fn block_local<N, T, const DASHPOT: bool, const ROT: bool, const DAMP: bool, const LOCAL: bool>(
    m: &mut Model,
    plan: &StepPlan,
    scratch: &mut PairScratch,
    damping_c: &[f64],
) -> (Breaks, WallLoads)
where
    N: NormalLaw,
    T: TangentialLaw,
{
    let n = m.particles.len();
    let mut ends = Vec::new();
    node_ends(0..n, NODE_BLOCKS, &mut ends);
    let from_records = scratch.begin_pass();
    let k = Motion::of(m);
    let nw = m.walls.len();
    let Model { particles: p, contacts: c, wall_contacts, walls, .. } = m;
    let cx = PairPass::of(plan, k.dt, (&p.radius, &p.mass, &p.material), c, from_records);
    let pair_start = &c.pair_start[..];
    // The pairs between nodes: particle `i` owns those of its row's tail that end at or past
    // its node's end.
    let mut breaks = {
        let kin = Kinematics::of::<ROT>(p, 0);
        let ends = &ends[..];
        for_blocks(0..n, Rows::Csr(pair_start), (), scratch.lanes::<T>(), &|range, (), (out, mut dashpots)| {
            let base = pair_start[range.start] as usize;
            let node_end = ends[ends.partition_point(|&e| e <= range.start)];
            let mut breaks = Breaks::default();
            for i in range.clone() {
                let tail = cx.owned(i);
                let inside = cx.below(&tail, node_end);
                let (k0, k1) = (pair_start[i] as usize - base + inside, pair_start[i + 1] as usize - base);
                let records = &mut out[k0..k1];
                let dashpots = dashpots.as_deref_mut().map(|d| &mut d[k0..k1]);
                let crossing = tail.start + inside..tail.end;
                cx.owned_pairs::<N, T, DASHPOT, ROT>(&kin, i, crossing, records, dashpots, &mut breaks);
            }
            breaks
        })
    };
    // Each node: its inner pairs, then its particles finish their step.
    let records = SharedRecords::new(scratch);
    let (row_start, pair, near) = (&c.row_start[..], &c.pair[..], &c.wall_near[..]);
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
    let (inner_breaks, loads): (Breaks, WallLoads) =
        for_nodes(0..n, NODE_BLOCKS, (loads_lanes, motion_lanes), &|node, (loads_lanes, motion_lanes)| {
            let mut breaks = Breaks::default();
            {
                let (pos, vel, spin_lanes, _) = &motion_lanes;
                let ang_vel = spin_lanes.as_ref().map(|(w, _)| &w[..]);
                let kin = Kinematics { pos, vel, ang_vel, first: node.start };
                for i in node.clone() {
                    let tail = cx.owned(i);
                    let inside = cx.below(&tail, node.end);
                    let k0 = pair_start[i] as usize;
                    // SAFETY: these pairs have both ends in this node, and only this task
                    // touches their records during the pass.
                    let (out, dashpots) = unsafe { records.owned_mut(k0..k0 + inside) };
                    let inner = tail.start..tail.start + inside;
                    cx.owned_pairs::<N, T, DASHPOT, ROT>(&kin, i, inner, out, dashpots, &mut breaks);
                }
            }
            let loads = for_blocks(
                node,
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
                        let row = gather_row::<T, ROT>(&records, &pair[start..end], own - start, ri, None);
                        let (mut f, mut t) = (row.force, row.torque);
                        heat.book_row(li, &row);
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
                            particle_walls::<N, T, DASHPOT>(
                                walls, plan, k.dt, near[i], &body, wall_st, &mut out, &mut loads,
                            );
                        }
                        force[li] = f;
                        // integrate: body forces, damping and the move.
                        let c = if DAMP { damping_c[i] } else { 0.0 };
                        let b = Translation { mass: mass[i], damping_c: c, fixed: fixed[i], force: f };
                        advance::<DAMP, LOCAL, false>(
                            &k,
                            &b,
                            &mut pos[li],
                            &mut vel[li],
                            heat.damping_at(li),
                            &mut unobserved,
                        );
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
            );
            (breaks, loads)
        });
    // Bonds that broke, in pair order (lower id, then higher), as one pair pass lists them.
    breaks.0.extend(inner_breaks.0);
    breaks.0.sort_unstable_by_key(|&(i, j, _)| (i, j));
    (breaks, loads)
}
