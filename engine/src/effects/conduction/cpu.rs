//! The `conduction` stage on the CPU: one field step of heat conduction after every
//! `every`-th mechanical step, in `substeps` forward-Euler sub-steps, then thermal expansion.
//!
//! Each element sums its own row, Q_i = P_i + Σ_j H_ij·(T_j − T_i) over the pairs that
//! overlap or are bonded (H from `physics::conduction`), and writes only its own next
//! temperature T_i + Δt·Q_i/C_i and its ΣH_i: no atomics, the same bits on any thread count.
//! The row sum and the update are the diffusion core moisture shares (`crate::diffusion`).
//! Both rows of a pair see the same H (it is symmetric), so with insulated boundaries Σ C·T
//! changes only by the sources, to round-off. Fixed elements keep their temperature; an
//! insulated element exchanges nothing. With expansion, r_i = r0_i·(1 + α_i·(T_i − T0)),
//! the mass kept: contacts and bonds see the new radii at the next force pass.

use crate::backend::cpu::blocks::{for_blocks, Rows};
use crate::backend::cpu::stage::{buffered, CpuStage};
use crate::diffusion::{self, Exchange};
use crate::effects::conduction::lanes::FIXED;
use crate::effects::conduction::physics::pair_conductance;
use crate::effects::conduction::ConductionPlan;
use crate::model::Model;
use crate::plan::StepPlan;

/// The stage's pass (`backend::cpu::stage::Build`), with its next temperatures kept between
/// steps.
pub fn stage(plan: &StepPlan) -> Option<Box<dyn CpuStage>> {
    plan.conduction.map(|plan| buffered(plan, conduction))
}

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

/// Heat's terms of the shared diffusion core: the source, and the Batchelor–O'Brien
/// conductance of each contact or bond.
struct Heat<'a> {
    source: &'a [f64],
    conductivity: &'a [f64],
    radius: &'a [f64],
    bond_radius: f64,
}

impl Exchange for Heat<'_> {
    #[inline(always)]
    fn own(&self, i: usize, _: f64) -> (f64, f64) {
        (self.source[i], 0.0)
    }

    #[inline(always)]
    fn pair(&self, i: usize, j: usize, dist: f64, bonded: bool) -> f64 {
        let (k, r) = (self.conductivity, self.radius);
        pair_conductance(k[i], k[j], r[i], r[j], dist, bonded, self.bond_radius)
    }
}

/// One forward-Euler sub-step: `next` gets each element's new temperature.
fn substep(m: &mut Model, plan: &ConductionPlan, dt: f64, next: &mut [f64]) {
    let sep = m.separations();
    let p = &mut m.particles;
    let c = &m.contacts;
    let th = &mut p.thermal;
    let heat =
        Heat { source: &th.source, conductivity: &th.conductivity, radius: &p.radius, bond_radius: plan.bond_radius };
    let (pos, t, cap, mode) = (&p.pos, &th.temperature, &th.capacity, &th.mode);
    for_blocks(0..pos.len(), Rows::None, (&mut next[..], &mut th.conductance[..]), (), &|range, (next, g), ()| {
        diffusion::substep(&heat, pos, &sep, c, t, cap, mode, dt, range, next, g)
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
