//! The `conduction` stage on the CPU: one field step of heat conduction after every
//! `every`-th mechanical step, in `substeps` forward-Euler sub-steps, then thermal expansion.
//!
//! Each element sums its own row, Q_i = P_i + Σ_j H_ij·(T_j − T_i) over the pairs that
//! overlap or are bonded (H from `physics::conduction`), and writes only its own next
//! temperature T_i + Δt·Q_i/C_i and its ΣH_i: no atomics, the same bits on any thread count.
//! Both rows of a pair see the same H (it is symmetric), so with insulated boundaries Σ C·T
//! changes only by the sources, to round-off. Fixed elements keep their temperature; an
//! insulated element exchanges nothing. With expansion, r_i = r0_i·(1 + α_i·(T_i − T0)),
//! the mass kept: contacts and bonds see the new radii at the next force pass.

use super::blocks::{for_blocks, Rows};
use crate::fields::ConductionPlan;
use crate::model::Model;
use crate::physics::conduction::pair_conductance;
use crate::state::thermal::{FIXED, INSULATED};

/// Runs the field step if it falls after the step that starts at `m.clock.step`. `next` is
/// the backend's scratch lane.
pub fn conduction(m: &mut Model, plan: &ConductionPlan, next: &mut Vec<f64>) {
    if !plan.runs_after(m.clock.step) {
        return;
    }
    let n = m.len();
    m.fit_thermal();
    if plan.dissipation {
        feed_dissipation(m);
    }
    let dt = plan.substep(m.clock.dt);
    next.resize(n, 0.0);
    for _ in 0..plan.substeps {
        substep(m, plan, dt, next);
        std::mem::swap(&mut m.particles.thermal.temperature, next);
    }
    if plan.expansion {
        expand(m, plan.reference);
    }
}

/// One forward-Euler sub-step: `next` gets each element's new temperature.
fn substep(m: &mut Model, plan: &ConductionPlan, dt: f64, next: &mut [f64]) {
    let p = &mut m.particles;
    let c = &m.contacts;
    let (pos, radius) = (&p.pos, &p.radius);
    let th = &mut p.thermal;
    let (t, cap, k, src, mode) = (&th.temperature, &th.capacity, &th.conductivity, &th.source, &th.mode);
    let beta = plan.bond_radius;
    for_blocks(0..pos.len(), Rows::None, (&mut next[..], &mut th.conductance[..]), (), &|range, (next, g), ()| {
        for i in range.clone() {
            let li = i - range.start;
            let mut q = src[i];
            let mut sum_h = 0.0;
            if mode[i] != INSULATED {
                for e in c.row(i) {
                    let j = c.other[e] as usize;
                    if mode[j] == INSULATED {
                        continue;
                    }
                    let d = (pos[j] - pos[i]).norm();
                    let h = pair_conductance(k[i], k[j], radius[i], radius[j], d, c.state[e].bonded, beta);
                    q += h * (t[j] - t[i]);
                    sum_h += h;
                }
            }
            g[li] = sum_h;
            next[li] = if mode[i] == FIXED { t[i] } else { t[i] + dt * q / cap[i] };
        }
    });
}

/// Adds the heat the ledger booked since the last field step to each free element.
fn feed_dissipation(m: &mut Model) {
    for i in 0..m.len() {
        let booked = m.booked_heat(i);
        let th = &mut m.particles.thermal;
        let new = booked - th.fed[i];
        th.fed[i] = booked;
        if th.mode[i] != FIXED && th.capacity[i] > 0.0 {
            th.temperature[i] += new / th.capacity[i];
        }
    }
}

/// r = r0·(1 + α·(T − T0)), mass kept.
fn expand(m: &mut Model, t0: f64) {
    let p = &mut m.particles;
    let th = &p.thermal;
    for (i, r) in p.radius.iter_mut().enumerate() {
        *r = th.radius0[i] * (1.0 + th.expansion[i] * (th.temperature[i] - t0));
    }
}
