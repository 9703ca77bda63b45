//! Stages 4–5: body forces, global viscous damping and leapfrog integration, in one pass.
//!
//! Velocities live at half steps. MatDEM's viscous damping −c·v is applied semi-implicitly
//! (with the mean of the old and new velocity), which is stable for any damping ratio and
//! makes the heat it books, c·|v̄|²·dt, exactly the work it removes.

use super::blocks::{for_blocks, Reduce, Rows};
use crate::model::Model;
use crate::physics::Vec3;
use crate::state::particles::dof;

/// What an observed step measures (J): the kinetic energy at the integer step and the heat
/// viscous damping releases during this step.
#[derive(Default, Clone, Copy)]
pub struct Observed {
    pub kinetic: f64,
    pub damping_heat: f64,
}

impl Reduce for Observed {
    fn combine(self, o: Self) -> Self {
        Observed { kinetic: self.kinetic + o.kinetic, damping_heat: self.damping_heat + o.damping_heat }
    }
}

/// Advances velocities and positions by one step; when `observe`, returns the kinetic energy
/// at the integer step (mean of the two half-step velocities) and this step's damping heat,
/// which spans the half steps either side of the integer time. Angular velocities
/// advance only when the plan simulates `rotation` (the lanes may outlive it, holding the
/// torques of the last step that computed them).
pub fn integrate(m: &mut Model, damping_c: &[f64], rotation: bool, observe: bool) -> Observed {
    let local = m.settings.local_damping > 0.0;
    macro_rules! go {
        ($($d:literal, $l:literal, $o:literal);+) => {
            match (!damping_c.is_empty(), local, observe) {
                $(($d, $l, $o) => integrate_loop::<$d, $l, $o>(m, damping_c, rotation),)+
            }
        };
    }
    go!(false, false, false; false, false, true; false, true, false; false, true, true;
        true, false, false; true, false, true; true, true, false; true, true, true)
}

fn integrate_loop<const DAMP: bool, const LOCAL: bool, const OBSERVE: bool>(
    m: &mut Model,
    damping_c: &[f64],
    rotation: bool,
) -> Observed {
    let dt = m.clock.dt;
    let alpha = m.settings.local_damping;
    let g = m.settings.gravity;
    let p = &mut m.particles;
    let n = p.len();
    let (mass, force, fixed, radius) = (&p.mass, &p.force, &p.fixed, &p.radius);
    let rot = p.rotation.as_mut().filter(|_| rotation).map(|r| (&mut r.ang_vel[..], &r.torque[..]));
    let mut obs = for_blocks(
        0..n,
        Rows::None,
        (&mut p.pos[..], &mut p.vel[..], &mut p.heat.damping[..]),
        (),
        &|range, (pos, vel, heat), ()| {
            let mut obs = Observed::default();
            for i in range.clone() {
                let li = i - range.start;
                let mi = mass[i];
                let v0 = vel[li];
                let mut f_total = force[i] + g * mi;
                let mut local_heat = 0.0;
                if LOCAL {
                    // Cundall's local damping: −α·|F|·sign(v) per component. It damps
                    // accelerations, not steady motion, so settling grains are not held back.
                    for k in 0..3 {
                        let fd = -alpha * f_total[k].abs() * v0[k].signum() * f64::from(u8::from(v0[k] != 0.0));
                        f_total[k] += fd;
                        local_heat -= fd * v0[k] * dt;
                    }
                }
                let accel = f_total / mi;
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
                if LOCAL {
                    heat[li] += local_heat;
                    if OBSERVE {
                        obs.damping_heat += local_heat;
                    }
                }
                if DAMP {
                    let h = damping_c[i] * v_mean.norm_squared() * dt;
                    heat[li] += h;
                    if OBSERVE {
                        obs.damping_heat += h;
                    }
                }
                if OBSERVE {
                    obs.kinetic += 0.5 * mi * v_mean.norm_squared();
                }
                vel[li] = v1;
                pos[li] += v1 * dt;
            }
            obs
        },
    );
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
                let h = damping_c[i] * w_mean.norm_squared() * dt * inertia / mass[i];
                p.heat.damping[i] += h;
                if OBSERVE {
                    obs.damping_heat += h;
                }
            }
            if OBSERVE {
                obs.kinetic += 0.5 * inertia * w_mean.norm_squared();
            }
            ang_vel[i] = w1;
        }
    }
    obs
}
