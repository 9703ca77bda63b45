//! Stage 3: contact forces between particles. Each particle walks its own row and sums
//! the forces on itself, so a pair is evaluated twice (once per row) and no two tasks
//! write the same memory. The loop is monomorphised for the plan's laws.

use super::blocks::{for_blocks, Reduce, Rows};
use crate::model::{Model, NormalKind, TangentialKind};
use crate::physics::contact_law::{
    contact, contact_opened, BreakKind, ContactGeometry, Hertz, Linear, LinearShear, MindlinShear, NormalLaw,
    PairState, TangentialLaw,
};
use crate::physics::Vec3;
use crate::plan::StepPlan;

/// Bonds that broke during the pass, in particle order: (i, j, kind) with i < j.
#[derive(Default)]
pub struct Breaks(pub Vec<(u32, u32, BreakKind)>);

impl Reduce for Breaks {
    fn combine(mut self, mut other: Self) -> Self {
        self.0.append(&mut other.0);
        self
    }
}

/// Overwrites `force` (and `torque`) with the contact forces of this step.
pub fn compute_contact_forces(m: &mut Model, plan: &StepPlan) -> Breaks {
    macro_rules! go {
        ($n:ty, $t:ty) => {
            match (plan.dashpot, plan.rotation) {
                (false, false) => contact_loop::<$n, $t, false, false>(m, plan),
                (true, false) => contact_loop::<$n, $t, true, false>(m, plan),
                (false, true) => contact_loop::<$n, $t, false, true>(m, plan),
                (true, true) => contact_loop::<$n, $t, true, true>(m, plan),
            }
        };
    }
    match (plan.normal, plan.tangential) {
        (NormalKind::Linear, TangentialKind::Linear) => go!(Linear, LinearShear),
        (NormalKind::Linear, TangentialKind::Mindlin) => go!(Linear, MindlinShear),
        (NormalKind::Hertz, TangentialKind::Linear) => go!(Hertz, LinearShear),
        (NormalKind::Hertz, TangentialKind::Mindlin) => go!(Hertz, MindlinShear),
    }
}

fn contact_loop<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool>(
    m: &mut Model,
    plan: &StepPlan,
) -> Breaks {
    let dt = m.clock.dt;
    let Model { particles: p, contacts: c, .. } = m;
    let n = p.len();
    let (pos, vel, radius, mass, material) = (&p.pos, &p.vel, &p.radius, &p.mass, &p.material);
    let (ang_vel, torque) = match &mut p.rotation {
        Some(r) if ROT => (Some(&r.ang_vel[..]), Some(&mut r.torque[..])),
        _ => (None, None),
    };
    let heat = &mut p.heat;
    let lanes = (
        &mut p.force[..],
        torque,
        &mut heat.contact_damping[..],
        &mut heat.friction[..],
        &mut heat.breakage[..],
    );
    let (row_start, other) = (&c.row_start[..], &c.other[..]);
    for_blocks(
        0..n,
        Rows::Csr(row_start),
        lanes,
        &mut c.state[..],
        &|range, (force, mut torque, h_damp, h_fric, h_break), state: &mut [PairState]| {
            let base = row_start[range.start] as usize;
            let mut breaks = Breaks::default();
            for i in range.clone() {
                let li = i - range.start;
                let (xi, ri, vi, mi, mati) = (pos[i], radius[i], vel[i], mass[i], material[i]);
                let wi = if ROT { ang_vel.map_or(Vec3::zeros(), |w| w[i]) } else { Vec3::zeros() };
                let (mut f, mut t) = (Vec3::zeros(), Vec3::zeros());
                let (mut hd, mut hf, mut hb) = (0.0, 0.0, 0.0);
                for e in row_start[i] as usize..row_start[i + 1] as usize {
                    let j = other[e] as usize;
                    let st = &mut state[e - base];
                    let d = pos[j] - xi;
                    let rj = radius[j];
                    let touch = ri + rj;
                    let dist2 = d.norm_squared();
                    if !st.bonded && dist2 >= touch * touch {
                        if st.shear != Vec3::zeros() || st.dashpot != 0.0 {
                            // The contact has just opened.
                            let nrm = d / dist2.sqrt();
                            let mut v_rel = vi - vel[j];
                            if ROT {
                                let wj = ang_vel.map_or(Vec3::zeros(), |w| w[j]);
                                v_rel += wi.cross(&(nrm * ri)) - wj.cross(&(nrm * -rj));
                            }
                            let pp = plan.pair(mati, material[j]);
                            let (friction, damping) = contact_opened::<T>(pp, ri * rj / touch, st, &nrm, v_rel, dt);
                            hf += friction;
                            hd += damping;
                        }
                        continue;
                    }
                    let dist = dist2.sqrt();
                    let nrm = d / dist;
                    let mut v_rel = vi - vel[j];
                    if ROT {
                        let wj = ang_vel.map_or(Vec3::zeros(), |w| w[j]);
                        v_rel += wi.cross(&(nrm * ri)) - wj.cross(&(nrm * -rj));
                    }
                    let mj = mass[j];
                    let g = ContactGeometry {
                        n: nrm,
                        overlap: touch - dist,
                        v_rel,
                        r_star: ri * rj / touch,
                        m_star: mi * mj / (mi + mj),
                    };
                    let r = contact::<N, T, DASHPOT>(&g, plan.pair(mati, material[j]), st, dt);
                    f += r.force;
                    if ROT {
                        t += (nrm * ri).cross(&r.shear);
                    }
                    hd += r.heat_damping;
                    hf += r.heat_friction;
                    hb += r.heat_breakage;
                    if let Some(kind) = r.broke {
                        if i < j {
                            breaks.0.push((i as u32, j as u32, kind));
                        }
                    }
                }
                force[li] = f;
                if let Some(tq) = torque.as_deref_mut() {
                    tq[li] = t;
                }
                // Each row books half of every pair's heat.
                h_damp[li] += 0.5 * hd;
                h_fric[li] += 0.5 * hf;
                h_break[li] += 0.5 * hb;
            }
            breaks
        },
    )
}
