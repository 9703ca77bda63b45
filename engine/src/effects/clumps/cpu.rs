//! The `clumps` stage on the CPU, right after the move (which leaves the members alone): each
//! clump's members' forces and torques summed about its centre, in member order, the body
//! advanced a step (`physics.rs`) and its members placed where it carries them. Serial, in clump
//! order (a scene's clumps are few beside its pairs); a member is in one clump, so each lane
//! entry is written once. CPU twin of `gpu.rs`.

use crate::backend::cpu::integrate::Observed;
use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::clumps::lanes::Body;
use crate::effects::clumps::physics::{free_rotation, rotational_energy};
use crate::effects::heat_ledger::cpu::{book, HeatLanes};
use crate::model::Model;
use crate::physics::Vec3;
use crate::plan::StepPlan;

/// The stage's pass (`backend::cpu::stage::Build`): the bodies' share of an observed step's
/// kinetic energy and damping heat.
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, s: &StageInput| Ok(Booked { observed: clumps(m, s.plan, s.damping_c), ..Booked::default() }))
}

/// Advances every clump by a step; returns the clumps' kinetic energy at the integer step and
/// the heat their damping released, for an observed step's energies.
pub fn clumps(m: &mut Model, plan: &StepPlan, damping_c: &[f64]) -> Observed {
    let (dt, alpha, gravity) = (m.clock.dt, m.settings.local_damping, m.settings.gravity);
    let planar = m.settings.planar.is_some();
    let mut obs = Observed::default();
    let p = &mut m.particles;
    let (force, pos) = (&p.force, &p.pos);
    let torque = p.rotation.as_ref().map(|r| &r.torque[..]);
    let mut heat = HeatLanes::of(&mut p.heat, &plan.heat);
    let cl = &mut m.clumps;
    for c in 0..cl.bodies.len() {
        let range = cl.range(c);
        let members = &cl.members[range];
        let b = &mut cl.bodies[c];
        // The loads on the body, about its centre at the start of the step.
        let (mut f, mut t) = (gravity * b.mass, Vec3::zeros());
        let mut c_sum = 0.0;
        for &j in members {
            let j = j as usize;
            f += force[j];
            t += (pos[j] - b.pos).cross(&force[j]);
            if let Some(tq) = torque {
                t += tq[j];
            }
            if !damping_c.is_empty() {
                c_sum += damping_c[j];
            }
        }
        if planar {
            // A 2D clump is held in y and in spin about x and z, as a 2D model's elements are.
            (f.y, t.x, t.z) = (0.0, 0.0, 0.0);
        }
        let h = step_body(b, f, t, alpha, c_sum, dt);
        obs.kinetic += h.kinetic;
        obs.damping_heat += h.heat;
        book(&mut heat.damping_at(members[0] as usize), h.heat);
    }
    for c in 0..m.clumps.bodies.len() {
        place_members(m, c);
        if let Some(r) = &mut m.particles.rotation {
            let w = m.clumps.bodies[c].ang_vel();
            for &j in &m.clumps.members[m.clumps.range(c)] {
                r.angle[j as usize] += w * dt;
            }
        }
    }
    obs
}

/// What one body's step released and held.
pub struct BodyStep {
    /// Kinetic energy at the integer step (J).
    pub kinetic: f64,
    /// Heat of the local and viscous damping (J).
    pub heat: f64,
}

/// Advances one body a step under force `f` (gravity included) and torque `t` about its
/// centre, with local damping `alpha` and viscous damping coefficient `c` (N·s/m; its rate c/M
/// damps the angular momentum too), both as the integration applies them to an element.
pub fn step_body(b: &mut Body, mut f: Vec3, mut t: Vec3, alpha: f64, c: f64, dt: f64) -> BodyStep {
    let q0 = b.rotation();
    let (v0, l0, w0) = (b.vel, b.ang_mom, b.ang_vel());
    let mut heat = 0.0;
    if alpha > 0.0 {
        for k in 0..3 {
            let fd = -alpha * f[k].abs() * v0[k].signum() * f64::from(u8::from(v0[k] != 0.0));
            let td = -alpha * t[k].abs() * w0[k].signum() * f64::from(u8::from(w0[k] != 0.0));
            f[k] += fd;
            t[k] += td;
            heat -= (fd * v0[k] + td * w0[k]) * dt;
        }
    }
    // Semi-implicit viscous damping, as for an element: a = ½·(c/M)·dt.
    let a = 0.5 * c / b.mass * dt;
    let v1 = (v0 * (1.0 - a) + f / b.mass * dt) / (1.0 + a);
    let l1 = (l0 * (1.0 - a) + t * dt) / (1.0 + a);
    let (v_mean, l_mean) = ((v0 + v1) * 0.5, (l0 + l1) * 0.5);
    if c > 0.0 {
        // c·|v̄|²·dt, and the same rate on the rotation: (c/M)·L̄·ω̄·dt.
        heat += c * v_mean.norm_squared() * dt + c / b.mass * 2.0 * rotational_energy(&q0, &l_mean, &b.inertia) * dt;
    }
    let kinetic = 0.5 * b.mass * v_mean.norm_squared() + rotational_energy(&q0, &l_mean, &b.inertia);
    b.vel = v1;
    b.pos += v1 * dt;
    b.ang_mom = l1;
    b.set_rotation(free_rotation(q0, &l1, &b.inertia, dt));
    BodyStep { kinetic, heat }
}

/// Puts clump c's members where its body carries them, with the velocities of its rigid
/// motion.
pub fn place_members(m: &mut Model, c: usize) {
    let (cl, p) = (&m.clumps, &mut m.particles);
    let b = &cl.bodies[c];
    let (q, w) = (b.rotation(), b.ang_vel());
    for k in cl.range(c) {
        let j = cl.members[k] as usize;
        let arm = q.transform_vector(&cl.offsets[k]);
        p.pos[j] = b.pos + arm;
        p.vel[j] = b.vel + w.cross(&arm);
        if let Some(r) = &mut p.rotation {
            r.ang_vel[j] = w;
        }
    }
}
