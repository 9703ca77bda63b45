//! The `moisture` stage on the CPU: one field step of moisture diffusion after every
//! `every`-th mechanical step, in `substeps` forward-Euler sub-steps of the diffusion core that
//! heat shares (`crate::diffusion`, water's terms in `crate::effects::moisture::WaterExchange`), then the
//! coupling: radii from the shrinkage table (times the thermal expansion's factor when heat
//! expands the elements too), bond shares from the strength table.
//!
//! Each element sums its own row and writes only its own next water content and ΣG: no
//! atomics, the same bits on any thread count. Both rows of a pair see the same G, so with
//! sealed boundaries and no evaporation Σ m·ω is conserved to round-off. Each bond's share is
//! computed by both of its rows from the pair's mean water content (symmetric), so the two
//! copies of the pair state stay identical.

use crate::backend::cpu::blocks::{for_blocks, Rows};
use crate::backend::cpu::stage::{buffered, CpuStage};
use crate::diffusion;
use crate::effects::moisture::{MoisturePlan, WaterExchange};
use crate::model::Model;
use crate::physics::contact_law::PairState;
use crate::plan::StepPlan;

/// The stage's pass (`backend::cpu::stage::Build`), with its next water contents kept between
/// steps.
pub fn stage(plan: &StepPlan) -> Option<Box<dyn CpuStage>> {
    plan.moisture.clone().map(|plan| buffered(plan, moisture))
}

/// Runs the field step if it falls after the step that starts at `m.clock.step`. `next` is
/// the backend's scratch lane.
pub fn moisture(m: &mut Model, plan: &MoisturePlan, next: &mut Vec<f64>) {
    if !plan.runs_after(m.clock.step) {
        return;
    }
    m.fit_moisture();
    let dt = plan.substep(m.clock.dt);
    next.resize(m.len(), 0.0);
    for _ in 0..plan.substeps {
        substep(m, plan, dt, next);
        std::mem::swap(&mut m.effects.moisture.lanes.water, next);
    }
    if let Some(t) = &plan.radius_table {
        match plan.expansion {
            None => {
                let w = &m.effects.moisture.lanes;
                for (i, r) in m.particles.radius.iter_mut().enumerate() {
                    *r = w.radius0[i] * t.at(w.water[i]);
                }
            }
            // With thermal expansion: r = r0·f(ω)·(1 + α·(T − T0)), and the expansion's r0
            // becomes r0·f(ω), which the conduction stage expands until the next field step.
            Some(t0) => {
                m.fit_thermal();
                let p = &mut m.particles;
                let (w, th) = (&m.effects.moisture.lanes, &mut p.thermal);
                for (i, r) in p.radius.iter_mut().enumerate() {
                    let base = w.radius0[i] * t.at(w.water[i]);
                    th.radius0[i] = base;
                    *r = base * (1.0 + th.expansion[i] * (th.temperature[i] - t0));
                }
            }
        }
    }
    if let Some(t) = &plan.strength_table {
        let w = &m.effects.moisture.lanes.water;
        let c = &mut m.contacts;
        let (row_start, other) = (&c.row_start, &c.other);
        for_blocks(0..w.len(), Rows::Csr(row_start), (), &mut c.state[..], &|range, (), state| {
            let first = row_start[range.start] as usize;
            for i in range {
                for e in row_start[i] as usize..row_start[i + 1] as usize {
                    let s = &mut state[e - first];
                    if s.bonded {
                        let j = other[e] as usize;
                        s.weakened = PairState::weakened_for(t.at(0.5 * (w[i] + w[j])));
                    }
                }
            }
        });
    }
}

/// One forward-Euler sub-step: `next` gets each element's new water content.
fn substep(m: &mut Model, plan: &MoisturePlan, dt: f64, next: &mut [f64]) {
    let sep = m.separations();
    let p = &m.particles;
    let c = &m.contacts;
    let w = &mut m.effects.moisture.lanes;
    let (pos, mass, radius) = (&p.pos, &p.mass, &p.radius);
    let water = WaterExchange {
        radius,
        diffusivity: &w.diffusivity,
        transfer: &w.transfer,
        ambient: &w.ambient,
        bond_radius: plan.bond_radius,
    };
    let (u, mode) = (&w.water, &w.mode);
    for_blocks(0..pos.len(), Rows::None, (&mut next[..], &mut w.conductance[..]), (), &|range, (next, g), ()| {
        diffusion::substep(&water, pos, &sep, c, u, mass, mode, dt, range, next, g)
    });
}
