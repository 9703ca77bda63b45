//! The `buoyancy` stage on the CPU: the water table's buoyant force −ρ_f·V_sub·g on every
//! element below the level (V_sub its submerged volume, a spherical cap where the level cuts
//! it; `physics::buoyancy`), and, with a viscosity, Stokes drag −6π·μ·r·v scaled by the
//! submerged fraction.
//!
//! It runs after integration, without a flag in the core's fused loop, and finishes the step
//! as if the core had integrated the buoyant acceleration b with the other forces: the
//! velocity gains b·dt/(1 + a) (a = c·dt/(2m), the semi-implicit viscous damping's factor, 0
//! without it) and the position that velocity times dt. With drag the step is the exact
//! solution of dv/dt = g + b − v/τ over dt (τ = m/(6π·μ·r·fraction)) from the velocity before
//! gravity's kick, so a sinking element reaches the Stokes terminal speed exactly and any
//! viscosity is stable. Local damping does not see buoyancy (it vanishes at rest, so
//! equilibria are unaffected). Blocked components are untouched; the force lane does not
//! carry buoyancy (it is a body force, like gravity).

use super::blocks::{for_blocks, Rows};
use crate::fields::BuoyancyPlan;
use crate::model::Model;
use crate::physics::buoyancy::submerged_volume;
use crate::state::particles::dof;

/// `damping_c`: each particle's viscous damping coefficient (empty when off).
pub fn buoyancy(m: &mut Model, plan: &BuoyancyPlan, damping_c: &[f64]) {
    let dt = m.clock.dt;
    let g = m.settings.gravity;
    let p = &mut m.particles;
    let (radius, mass, fixed) = (&p.radius, &p.mass, &p.fixed);
    let six_pi_mu = 6.0 * std::f64::consts::PI * plan.viscosity;
    for_blocks(0..radius.len(), Rows::None, (&mut p.pos[..], &mut p.vel[..]), (), &|range, (pos, vel), ()| {
        for i in range.clone() {
            let li = i - range.start;
            let r = radius[i];
            let v_sub = submerged_volume(pos[li].z, r, plan.level);
            if v_sub == 0.0 {
                continue;
            }
            let mi = mass[i];
            let kf = 1.0 / (1.0 + 0.5 * damping_c.get(i).copied().unwrap_or(0.0) * dt / mi);
            let b = -g * (plan.density * v_sub / mi);
            let fraction = v_sub / (4.0 / 3.0 * std::f64::consts::PI * r * r * r);
            let x = six_pi_mu * r * fraction * dt / mi;
            let decay = (-x).exp();
            // (1 − e^(−x))/x, 1 at x = 0.
            let phi = if x > 0.0 { -(-x).exp_m1() / x } else { 1.0 };
            let v1 = vel[li];
            let v = v1 * decay - g * (dt * kf * decay) + (g + b) * (dt * kf * phi);
            for (axis, bit) in [dof::X, dof::Y, dof::Z].into_iter().enumerate() {
                if fixed[i] & bit == 0 {
                    pos[li][axis] += (v[axis] - v1[axis]) * dt;
                    vel[li][axis] = v[axis];
                }
            }
        }
    });
}
