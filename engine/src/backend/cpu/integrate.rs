//! The `integrate` stage: body forces, global viscous damping and leapfrog integration, in one
//! pass.
//!
//! Velocities live at half steps. MatDEM's viscous damping −c·v is applied semi-implicitly
//! (with the mean of the old and new velocity), which is stable for any damping ratio and
//! makes the heat it books, c·|v̄|²·dt, exactly the work it removes.

use super::blocks::{for_blocks, Reduce, Rows};
use crate::effects::heat_ledger::cpu::{book, HeatLanes};
use crate::model::Model;
use crate::physics::Vec3;
use crate::plan::StepPlan;
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

/// Advances velocities and positions by one step, in a pass of its own, and returns the
/// kinetic energy at the integer step (mean of the two half-step velocities) and this step's
/// damping heat, which spans the half steps either side of the integer time. This is the
/// observed step's integration; unobserved steps integrate in the fused pass (fused.rs), with
/// the same per-particle code. Angular velocities advance only when the plan simulates
/// `rotation` (the lanes may outlive it, holding the torques of the last step that computed them).
pub fn integrate(m: &mut Model, plan: &StepPlan, damping_c: &[f64]) -> Observed {
    let (damp, local) = (!damping_c.is_empty(), m.settings.local_damping > 0.0);
    crate::with_flags!(integrate_loop[damp, local](m, plan, damping_c))
}

/// Per-step constants of the integration.
pub(super) struct Motion {
    pub dt: f64,
    /// Local damping coefficient α.
    pub alpha: f64,
    pub gravity: Vec3,
}

impl Motion {
    pub fn of(m: &Model) -> Self {
        Motion { dt: m.clock.dt, alpha: m.settings.local_damping, gravity: m.settings.gravity }
    }
}

fn integrate_loop<const DAMP: bool, const LOCAL: bool>(m: &mut Model, plan: &StepPlan, damping_c: &[f64]) -> Observed {
    let rotation = plan.rotation;
    let k = Motion::of(m);
    let p = &mut m.particles;
    let n = p.len();
    let (mass, force, fixed, radius) = (&p.mass, &p.force, &p.fixed, &p.radius);
    let rot = p.rotation.as_mut().filter(|_| rotation).map(|r| (&mut r.ang_vel[..], &r.torque[..], &mut r.angle[..]));
    let mut obs = for_blocks(
        0..n,
        Rows::None,
        (&mut p.pos[..], &mut p.vel[..], HeatLanes::of(&mut p.heat, &plan.heat)),
        (),
        &|range, (pos, vel, mut heat), ()| {
            let mut obs = Observed::default();
            for i in range.clone() {
                let li = i - range.start;
                let c = if DAMP { damping_c[i] } else { 0.0 };
                let body = Translation { mass: mass[i], damping_c: c, fixed: fixed[i], force: force[i] };
                advance::<DAMP, LOCAL, true>(&k, &body, &mut pos[li], &mut vel[li], heat.damping_at(li), &mut obs);
            }
            obs
        },
    );
    if let Some((ang_vel, torque, angle)) = rot {
        // A plain loop after the translations, so the energies an observed step sums come
        // out in the same order as ever; unobserved steps spin in the fused pass (fused.rs).
        let mut heat = HeatLanes::of(&mut p.heat, &plan.heat);
        for i in 0..n {
            let c = if DAMP { damping_c[i] } else { 0.0 };
            let (ti, wi, ai) = (torque[i], &mut ang_vel[i], &mut angle[i]);
            spin::<DAMP, true>(k.dt, mass[i], radius[i], c, fixed[i], ti, wi, ai, heat.damping_at(i), &mut obs);
        }
    }
    obs
}

/// What the translation of one particle reads.
pub(super) struct Translation {
    pub mass: f64,
    /// Viscous damping coefficient c (0 when damping is off).
    pub damping_c: f64,
    pub fixed: u8,
    /// Contact and wall force of this step.
    pub force: Vec3,
}

/// Advances one particle's velocity and position by a step; books its damping heat.
#[inline(always)]
pub(super) fn advance<const DAMP: bool, const LOCAL: bool, const OBSERVE: bool>(
    k: &Motion,
    b: &Translation,
    pos: &mut Vec3,
    vel: &mut Vec3,
    mut heat: Option<&mut f64>,
    obs: &mut Observed,
) {
    let (dt, mi) = (k.dt, b.mass);
    let v0 = *vel;
    let mut f_total = b.force + k.gravity * mi;
    let mut local_heat = 0.0;
    if LOCAL {
        // Cundall's local damping: −α·|F|·sign(v) per component. It damps
        // accelerations, not steady motion, so settling grains are not held back.
        for c in 0..3 {
            let fd = -k.alpha * f_total[c].abs() * v0[c].signum() * f64::from(u8::from(v0[c] != 0.0));
            f_total[c] += fd;
            local_heat -= fd * v0[c] * dt;
        }
    }
    let accel = f_total / mi;
    let mut v1 = if DAMP {
        let a = 0.5 * b.damping_c * dt / mi;
        (v0 * (1.0 - a) + accel * dt) / (1.0 + a)
    } else {
        v0 + accel * dt
    };
    let f = b.fixed;
    if f != 0 {
        if f & dof::CLUMPED != 0 {
            // Its clump moves it (the `clumps` stage, next): checked in the branch fixed
            // elements take anyway, so a scene without clumps pays nothing for it.
            return;
        }
        for (c, bit) in [dof::X, dof::Y, dof::Z].into_iter().enumerate() {
            if f & bit != 0 {
                v1[c] = v0[c];
            }
        }
    }
    let v_mean = (v0 + v1) * 0.5;
    if LOCAL {
        book(&mut heat, local_heat);
        if OBSERVE {
            obs.damping_heat += local_heat;
        }
    }
    if DAMP {
        let h = b.damping_c * v_mean.norm_squared() * dt;
        book(&mut heat, h);
        if OBSERVE {
            obs.damping_heat += h;
        }
    }
    if OBSERVE {
        obs.kinetic += 0.5 * mi * v_mean.norm_squared();
    }
    *vel = v1;
    *pos += v1 * dt;
}

/// Advances one particle's angular velocity by a step under `torque`, with the same damping
/// form as the translation, and its accumulated rotation by the new (half-step) angular
/// velocity times dt, as the position moves with the velocity; books its damping heat. A
/// component whose rotation is fixed (`dof::RX`, `RY`, `RZ` in `fixed`) keeps its value, as a
/// fixed translation does.
#[inline(always)]
pub(super) fn spin<const DAMP: bool, const OBSERVE: bool>(
    dt: f64,
    mass: f64,
    radius: f64,
    damping_c: f64,
    fixed: u8,
    torque: Vec3,
    ang_vel: &mut Vec3,
    angle: &mut Vec3,
    mut heat: Option<&mut f64>,
    obs: &mut Observed,
) {
    let inertia = 0.4 * mass * radius * radius;
    let w0 = *ang_vel;
    let mut w1 = if DAMP {
        let a = 0.5 * damping_c * dt / mass;
        (w0 * (1.0 - a) + torque / inertia * dt) / (1.0 + a)
    } else {
        w0 + torque / inertia * dt
    };
    if fixed & (dof::ROTATION | dof::CLUMPED) != 0 {
        if fixed & dof::CLUMPED != 0 {
            return;
        }
        for (c, bit) in [dof::RX, dof::RY, dof::RZ].into_iter().enumerate() {
            if fixed & bit != 0 {
                w1[c] = w0[c];
            }
        }
    }
    let w_mean: Vec3 = (w0 + w1) * 0.5;
    if DAMP {
        let h = damping_c * w_mean.norm_squared() * dt * inertia / mass;
        book(&mut heat, h);
        if OBSERVE {
            obs.damping_heat += h;
        }
    }
    if OBSERVE {
        obs.kinetic += 0.5 * inertia * w_mean.norm_squared();
    }
    *ang_vel = w1;
    *angle += w1 * dt;
}
