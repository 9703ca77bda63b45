//! The stability guard: cheap periodic checks that stop a run before it produces NaNs, with
//! a message naming the particle, the critical time step and the fix.

use crate::error::{Error, Instability, Result};
use crate::model::Model;

/// Refuses a time step above the critical step of the stiffest element.
pub fn check_time_step(m: &Model) -> Result<()> {
    let dt = m.clock.dt;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::InvalidScene(
            "the time step is not set: call set_standard_dt() or set dt to a positive value".into(),
        ));
    }
    if let Some((i, crit)) = m.critical_dt() {
        if dt > crit {
            return Err(unstable(
                m,
                i,
                format!("(the stiffest element) cannot be integrated: dt is {:.1}× its critical step", dt / crit),
            ));
        }
    }
    Ok(())
}

/// Non-finite state, runaway speeds and deep overlaps.
pub fn check_state(m: &Model) -> Result<()> {
    let p = &m.particles;
    let dt = m.clock.dt;
    for i in 0..p.len() {
        let (x, v, f) = (p.pos[i], p.vel[i], p.force[i]);
        if !(x.iter().chain(v.iter()).chain(f.iter()).all(|c| c.is_finite())) {
            return Err(unstable(m, i, "has a non-finite position, velocity or force".into()));
        }
        let travel = v.norm() * dt;
        if travel > 0.5 * p.radius[i] {
            return Err(unstable(
                m,
                i,
                format!(
                    "moves {:.0}% of its radius per step (speed {:.3e} m/s)",
                    100.0 * travel / p.radius[i],
                    v.norm()
                ),
            ));
        }
    }
    let c = &m.contacts;
    let ratio = m.settings.max_overlap_ratio;
    for i in 0..p.len() {
        for k in c.row(i) {
            let j = c.other[k] as usize;
            let rmin = p.radius[i].min(p.radius[j]);
            let overlap = p.radius[i] + p.radius[j] - (p.pos[j] - p.pos[i]).norm();
            if overlap > ratio * rmin {
                return Err(unstable(
                    m,
                    i,
                    format!("overlaps particle {j} by {:.0}% of the smaller radius", 100.0 * overlap / rmin),
                ));
            }
        }
        for w in &m.walls {
            let (_, gap) = w.normal_and_distance(&p.pos[i]);
            if p.radius[i] - gap > ratio * p.radius[i] {
                return Err(unstable(m, i, format!("is pushed through wall `{}`", w.name)));
            }
        }
    }
    Ok(())
}

pub(crate) fn unstable(m: &Model, particle: usize, what: String) -> Error {
    let (_, critical_dt) = m.critical_dt().unwrap_or((particle, f64::NAN));
    Error::Unstable(Box::new(Instability {
        step: m.clock.step,
        particle,
        what,
        dt: m.clock.dt,
        critical_dt,
        standard_dt: m.standard_dt().unwrap_or(f64::NAN),
    }))
}
