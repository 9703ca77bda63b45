//! Stages 4–5: body forces, global viscous damping and leapfrog integration, in one pass.
//!
//! Velocities live at half steps. MatDEM's viscous damping −c·v is applied semi-implicitly
//! (with the mean of the old and new velocity), which is stable for any damping ratio and
//! makes the heat it books, c·|v̄|²·dt, exactly the work it removes.

use super::blocks::{for_blocks, Reduce, Rows};
use crate::model::Model;
use crate::physics::Vec3;
use crate::state::particles::dof;

/// Kinetic energy at the integer step, when asked for (J).
#[derive(Default)]
pub struct Kinetic(pub f64);

impl Reduce for Kinetic {
    fn combine(self, o: Self) -> Self {
        Kinetic(self.0 + o.0)
    }
}

/// Advances velocities and positions by one step; returns the kinetic energy at the
/// integer step (mean of the two half-step velocities) when `observe`.
pub fn integrate(m: &mut Model, damping_c: &[f64], observe: bool) -> f64 {
    match (damping_c.is_empty(), observe) {
        (true, false) => integrate_loop::<false, false>(m, damping_c),
        (true, true) => integrate_loop::<false, true>(m, damping_c),
        (false, false) => integrate_loop::<true, false>(m, damping_c),
        (false, true) => integrate_loop::<true, true>(m, damping_c),
    }
}

fn integrate_loop<const DAMP: bool, const OBSERVE: bool>(m: &mut Model, damping_c: &[f64]) -> f64 {
    let dt = m.clock.dt;
    let g = m.settings.gravity;
    let p = &mut m.particles;
    let n = p.len();
    let (mass, force, fixed, radius) = (&p.mass, &p.force, &p.fixed, &p.radius);
    let rot = p.rotation.as_mut().map(|r| (&mut r.ang_vel[..], &r.torque[..]));
    let ke = for_blocks(
        0..n,
        Rows::None,
        (&mut p.pos[..], &mut p.vel[..], &mut p.heat.damping[..]),
        (),
        &|range, (pos, vel, heat), ()| {
            let mut ke = 0.0;
            for i in range.clone() {
                let li = i - range.start;
                let mi = mass[i];
                let v0 = vel[li];
                let accel = force[i] / mi + g;
                let mut v1 = if DAMP {
                    let a = 0.5 * damping_c[i] * dt / mi;
                    (v0 * (1.0 - a) + accel * dt) / (1.0 + a)
                } else {
                    v0 + accel * dt
                };
                let f = fixed[i];
                if f != 0 {
                    for (k, bit) in [dof::X, dof::Y, dof::Z].into_iter().enumerate() {
                        if f & bit != 0 {
                            v1[k] = v0[k];
                        }
                    }
                }
                let v_mean = (v0 + v1) * 0.5;
                if DAMP {
                    heat[li] += damping_c[i] * v_mean.norm_squared() * dt;
                }
                if OBSERVE {
                    ke += 0.5 * mi * v_mean.norm_squared();
                }
                vel[li] = v1;
                pos[li] += v1 * dt;
            }
            Kinetic(ke)
        },
    )
    .0;
    let mut rot_ke = 0.0;
    if let Some((ang_vel, torque)) = rot {
        // Rotation is rare and cheap next to contacts: a plain loop, same damping form.
        for i in 0..n {
            let inertia = 0.4 * mass[i] * radius[i] * radius[i];
            let w0 = ang_vel[i];
            let w1 = if DAMP {
                let a = 0.5 * damping_c[i] * dt / mass[i];
                (w0 * (1.0 - a) + torque[i] / inertia * dt) / (1.0 + a)
            } else {
                w0 + torque[i] / inertia * dt
            };
            let w_mean: Vec3 = (w0 + w1) * 0.5;
            if DAMP {
                p.heat.damping[i] += damping_c[i] * w_mean.norm_squared() * dt * inertia / mass[i];
            }
            if OBSERVE {
                rot_ke += 0.5 * inertia * w_mean.norm_squared();
            }
            ang_vel[i] = w1;
        }
    }
    ke + rot_ke
}
