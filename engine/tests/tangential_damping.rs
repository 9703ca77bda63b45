//! Hertz–Mindlin with a tangential dashpot (`TangentialKind::MindlinDamped`, LIGGGHTS'
//! `tangential_damping on`) against the analytic damped oscillator, its energy account, the
//! Coulomb cap on spring + dashpot together, and the GPU against the CPU.
//!
//! The scene: a sphere resting on a rigid floor under gravity at its equilibrium overlap
//! δ0 (Kh·δ0^{3/2} = m·g, Kh = 4/3·E*·√R), rotation off, μ large, displaced tangentially
//! (its shear spring wound by A) and let go from rest. The normal overlap stays δ0 (the
//! tangential law does not couple into the normal one), so the tangential contact is a
//! linear spring–dashpot on the sphere's mass:
//!   k_t = 8·G*·√(R·δ0),  c_t = 2·√(5/6)·|β|·√(k_t·m),  β = ln e/√(ln²e + π²),
//! with the effective mass m (rigid wall, no rotation). Its damping ratio is
//! ζ_t = c_t/(2·√(k_t·m)) = √(5/6)·|β|, its period 2π/ω_d with ω_d = √(k_t/m)·√(1 − ζ_t²),
//! and successive maxima of the displacement shrink by the log decrement
//! Λ = 2π·ζ_t/√(1 − ζ_t²).

use crate::common::{material, rel, run};
use matdem_engine::{Model, NormalKind, Simulation, TangentialKind, Vec3, Wall};
use std::f64::consts::PI;

const R: f64 = 0.005;
const YOUNG: f64 = 5e7;
const NU: f64 = 0.25;
const RHO: f64 = 2650.0;
const G: f64 = 9.81;
const E: f64 = 0.7;

/// The closed-form oscillator of the module's scene.
struct Oscillator {
    mass: f64,
    overlap: f64,
    kt: f64,
    zeta_t: f64,
    omega_d: f64,
    log_decrement: f64,
}

impl Oscillator {
    fn new() -> Self {
        let mass = RHO * 4.0 / 3.0 * PI * R.powi(3);
        // A rigid wall: E* = E/(1 − ν²), G* = G/(2 − ν) with G = E/(2(1 + ν)).
        let e_star = YOUNG / (1.0 - NU * NU);
        let g_star = YOUNG / (2.0 * (1.0 + NU)) / (2.0 - NU);
        let kh = 4.0 / 3.0 * e_star * R.sqrt();
        let overlap = (mass * G / kh).powf(2.0 / 3.0);
        let kt = 8.0 * g_star * (R * overlap).sqrt();
        let beta = E.ln() / (E.ln().powi(2) + PI * PI).sqrt();
        let zeta_t = (5.0f64 / 6.0).sqrt() * beta.abs();
        let omega_d = (kt / mass).sqrt() * (1.0 - zeta_t * zeta_t).sqrt();
        let log_decrement = 2.0 * PI * zeta_t / (1.0 - zeta_t * zeta_t).sqrt();
        Oscillator { mass, overlap, kt, zeta_t, omega_d, log_decrement }
    }
}

/// The sphere on the floor at its equilibrium overlap with friction `mu`, Hertz–Mindlin
/// with the tangential dashpot, one step 1/`per_period` of the undamped tangential period:
/// moving sideways at `v0` with a relaxed shear spring, or at rest with the spring wound by a
/// displacement `a0` (the sphere displaced tangentially and let go; x is then measured from
/// the displaced position).
fn pressed_sphere(v0: f64, a0: f64, mu: f64, per_period: f64) -> Model {
    let o = Oscillator::new();
    let mut mat = material("sand", RHO, 1e5, YOUNG, NU);
    mat.restitution = E;
    mat.mu_p = mu;
    let mut m = Model::new();
    m.settings.normal = NormalKind::Hertz;
    m.settings.tangential = TangentialKind::MindlinDamped;
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    let k = m.add_material(mat).unwrap();
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
    let a = m.add_particle(Vec3::new(0.0, 0.0, R - o.overlap), R, k).unwrap();
    m.particles.vel[a] = Vec3::new(v0, 0.0, 0.0);
    // The spring's force on the sphere, −k_t·a0, pulls it back.
    m.wall_contacts[a].shear = Vec3::new(-o.kt * a0, 0.0, 0.0);
    m.set_dt(2.0 * PI * (o.mass / o.kt).sqrt() / per_period).unwrap();
    m
}

/// Displacement the spring is wound by in the ringing tests (m): a tenth of the overlap,
/// k_t·A = 1.8e-3 N against μ·m·g = 6.8e-2 N.
const A0: f64 = 2e-7;

/// The oscillation's damped angular frequency and log decrement, from the sphere's velocity
/// (which, unlike x, oscillates about zero whatever the spring's origin): the spacing of its
/// zero crossings (linearly interpolated) is π/ω_d, and its extremes shrink by e^{−Λ/2} per
/// half period (the first and the last seen). Samples every `every` steps for `periods`
/// damped periods.
fn measure(sim: &mut Simulation, periods: usize, every: u64) -> (f64, f64) {
    let o = Oscillator::new();
    let steps = (periods as f64 * 2.0 * PI / o.omega_d / sim.model.clock.dt / every as f64).ceil() as usize;
    let mut vs = Vec::with_capacity(steps);
    for _ in 0..steps {
        run(sim, every).expect("the guard must not stop the run");
        vs.push((sim.model.clock.time, sim.model.particles.vel[0].x));
    }
    let mut crossings = Vec::new();
    for w in vs.windows(2) {
        let ((t0, v0), (t1, v1)) = (w[0], w[1]);
        if v0 != 0.0 && v0.signum() != v1.signum() {
            crossings.push(t0 + (t1 - t0) * v0 / (v0 - v1));
        }
    }
    assert!(crossings.len() >= 2 * periods - 1, "{} zero crossings in {periods} periods", crossings.len());
    let half = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    // The largest |v| of each half period between two crossings.
    let mut extremes = Vec::new();
    let mut lobe = 0.0f64;
    for w in vs.windows(2) {
        lobe = lobe.max(w[0].1.abs());
        if w[0].1 != 0.0 && w[0].1.signum() != w[1].1.signum() {
            extremes.push(lobe);
            lobe = 0.0;
        }
    }
    let n = extremes.len() - 1;
    assert!(n >= 4, "{} extremes", extremes.len());
    (PI / half, 2.0 * (extremes[0] / extremes[n]).ln() / n as f64)
}

// The tangential spring–dashpot rings at ω_d = √(k_t/m)·√(1 − ζ_t²) and decays by
// Λ = 2π·ζ_t/√(1 − ζ_t²), ζ_t = √(5/6)·|β| (e = 0.7: ζ_t = 0.103), within 1 % and 2 %
// (200 steps per period: the leapfrog's dashpot reads the half-step velocity, which shifts
// ω_d by about ½·ζ_t·ω·dt = 1.6e-3).
#[test]
fn tangential_dashpot_rings_at_the_damped_frequency_and_decays_by_the_log_decrement() {
    let o = Oscillator::new();
    let mut sim = Simulation::new(pressed_sphere(0.0, A0, 5.0, 200.0));
    let (omega, decrement) = measure(&mut sim, 6, 1);
    eprintln!(
        "δ0 = {:.3e} m, k_t = {:.4e} N/m, ζ_t = {:.4}: ω_d {omega:.2} vs {:.2} rad/s ({:+.2e}), Λ {decrement:.4} vs {:.4} ({:+.2e})",
        o.overlap,
        o.kt,
        o.zeta_t,
        o.omega_d,
        omega / o.omega_d - 1.0,
        o.log_decrement,
        decrement / o.log_decrement - 1.0
    );
    assert!(rel(omega, o.omega_d) < 0.01, "ω_d {omega} vs {}", o.omega_d);
    assert!(rel(decrement, o.log_decrement) < 0.02, "Λ {decrement} vs {}", o.log_decrement);
}

// Without the dashpot (plain Mindlin) the same oscillation does not decay: the damping is the
// law's, not the integrator's.
#[test]
fn plain_mindlin_spring_rings_without_decay() {
    let mut m = pressed_sphere(0.0, A0, 5.0, 200.0);
    m.settings.tangential = TangentialKind::Mindlin;
    let (omega, decrement) = measure(&mut Simulation::new(m), 4, 1);
    eprintln!("plain mindlin: ω {omega:.2}, Λ {decrement:.3e}");
    assert!(decrement.abs() < 1e-3, "Λ {decrement}");
}

// The energy account closes with the dashpot's heat: kinetic + elastic + gravitational +
// heat stays at its start within 4e-3 of the oscillation's energy ½·k_t·A² while it rings
// down (the dashpot's heat is booked as c_t·|v_t|²·dt with the force of the step, which leads
// the trapezoid of the account by ¼·c_t·dt·Δ|v_t|²: at most ζ_t·ω·dt ≈ 3.2e-3 of the energy
// in motion, nothing once the sphere is at rest again), and all of ½·k_t·A² but what still
// rings ends as contact-damping heat (within 1e-3).
#[test]
fn energy_account_closes_with_the_tangential_dashpot_heat() {
    let o = Oscillator::new();
    let scale = 0.5 * o.kt * A0 * A0;
    let mut sim = Simulation::new(pressed_sphere(0.0, A0, 5.0, 200.0));
    let mut log = Vec::new();
    sim.run_sampled(2400, 5, &Default::default(), &mut |_| {}, &mut |s| log.push(s.energies)).unwrap();
    let e0 = log[0].total();
    let worst = log.iter().map(|e| (e.total() - e0).abs()).fold(0.0, f64::max) / scale;
    let end = log.last().unwrap();
    let heat = end.heat_contact_damping / scale;
    let left = (end.kinetic + end.shear_elastic) / scale;
    eprintln!(
        "account off by at most {worst:.2e} of ½k_tA²; contact-damping heat {heat:.5} of it, {left:.2e} still ringing"
    );
    assert!(worst < 4e-3, "energy account off by {worst:e}");
    assert!(left < 1e-3 && (heat + left - 1.0).abs() < 1e-3, "heat {heat}, left {left}");
    assert_eq!(end.heat_friction, 0.0, "μ large: no sliding");
}

// Sliding: spring + dashpot together are capped at μ·Fn (LIGGGHTS), so a sphere pushed
// along the floor at 0.2 m/s with μ = 0.3 slows at μ·g and stops after v0²/(2·μ·g) (within
// 1 %: the first steps load the spring). The heat of a sliding step is friction heat, spring
// and dashpot together: here c_t·v0 is 35·μ·Fn, and the dashpot clipped to the cap leaves the
// spring relaxed instead of wound against the slip (LAMMPS' rescale would store energy no
// force supplied), so the account closes within 1e-3 of the kinetic energy lost, nearly all
// of it friction heat, and no lane books negative heat.
#[test]
fn spring_and_dashpot_slide_together_at_mu_fn() {
    let (v0, mu) = (0.2, 0.3);
    let o = Oscillator::new();
    let mut sim = Simulation::new(pressed_sphere(v0, 0.0, mu, 200.0));
    let mut log = Vec::new();
    let t_stop = v0 / (mu * G);
    let steps = (1.2 * t_stop / sim.model.clock.dt) as u64;
    let mut sliding_forces = Vec::new();
    let mut stopped_at = None;
    let x0 = sim.model.particles.pos[0].x;
    for k in 0..steps / 10 {
        sim.run_sampled(10, 10, &Default::default(), &mut |_| {}, &mut |s| log.push(s.energies)).unwrap();
        let p = &sim.model.particles;
        if p.vel[0].x > 0.05 && k > 2 {
            sliding_forces.push(p.force[0].x);
        }
        if stopped_at.is_none() && p.vel[0].x <= 0.0 {
            stopped_at = Some((sim.model.clock.time, p.pos[0].x - x0));
        }
    }
    let (t, d) = stopped_at.expect("the sphere must stop");
    let expected = v0 * v0 / (2.0 * mu * G);
    eprintln!("stopped after {t:.4e} s (analytic {t_stop:.4e}), {d:.4e} m (analytic {expected:.4e})");
    assert!(rel(t, t_stop) < 0.01 && rel(d, expected) < 0.01);
    for f in &sliding_forces {
        assert!(rel(-f, mu * o.mass * G) < 1e-6, "sliding force {f} vs μ·m·g {}", mu * o.mass * G);
    }
    let scale = 0.5 * o.mass * v0 * v0;
    let e0 = log[0].total();
    let worst = log.iter().map(|e| (e.total() - e0).abs()).fold(0.0, f64::max) / scale;
    let end = log.last().unwrap();
    eprintln!(
        "account off by {worst:.2e}; friction heat {:.4}, damping heat {:.4} of ½mv0²",
        end.heat_friction / scale,
        end.heat_contact_damping / scale
    );
    assert!(worst < 1e-3, "energy account off by {worst:e}");
    // Sliding dissipates friction heat; the dashpot's share is the stick after the stop.
    assert!(end.heat_friction / scale > 0.99, "friction heat {}", end.heat_friction / scale);
    assert!(end.heat_contact_damping >= 0.0, "damping heat {}", end.heat_contact_damping);
}

// The plan names the law, and says when no material gives the dashpot anything to do.
#[test]
fn the_plan_names_the_tangential_dashpot() {
    let mut m = pressed_sphere(0.0, A0, 5.0, 200.0);
    let text = Simulation::new(m.clone()).plan().to_string();
    assert!(text.contains("hertz + mindlin shear spring + tangential dashpot + coulomb"), "{text}");
    m.materials[0].restitution = 1.0;
    let text = Simulation::new(m).plan().to_string();
    assert!(text.contains("tangential dashpot (0: every e = 1)"), "{text}");
}

#[cfg(feature = "gpu")]
mod gpu {
    use super::*;
    use crate::common::{gpu, probe_wall, run_impact, sphere_on_plane};

    // The GPU rings like the CPU: ω_d and Λ within 0.5 % of the CPU's (x sampled every 4
    // steps on both) and within 1 % and 3 % of the analytic answer.
    #[test]
    fn tangential_dashpot_oscillation_matches_cpu() {
        let Some(ctx) = gpu("tangential_dashpot_oscillation") else { return };
        let o = Oscillator::new();
        let m = pressed_sphere(0.0, A0, 5.0, 200.0);
        let (wa, la) = measure(&mut Simulation::new(m.clone()), 4, 4);
        let (wb, lb) = measure(&mut Simulation::with_gpu(m, ctx), 4, 4);
        eprintln!(
            "cpu ω_d {wa:.3} Λ {la:.5}; gpu ω_d {wb:.3} Λ {lb:.5}; analytic {:.3} {:.5}",
            o.omega_d, o.log_decrement
        );
        assert!(rel(wb, wa) < 5e-3 && rel(lb, la) < 5e-3);
        assert!(rel(wb, o.omega_d) < 0.01 && rel(lb, o.log_decrement) < 0.03);
    }

    // An oblique Hertz impact on the floor with rotation, restitution 0.5 and friction, then a
    // pair of spheres meeting obliquely: the rebound, the tangential speed and the spin after
    // contact equal the CPU's within 1e-3 (the wall kernel and the pair kernel).
    #[test]
    fn tangential_dashpot_impacts_match_cpu() {
        let Some(ctx) = gpu("tangential_dashpot_impacts") else { return };
        let mut mat = material("glass", 2800.0, 1e6, 4.8e10, 0.2);
        mat.restitution = 0.5;
        mat.mu_p = 0.4;
        let mut model = sphere_on_plane(mat.clone(), 0.005, 1e-6, 1.0, NormalKind::Hertz);
        model.settings.tangential = TangentialKind::MindlinDamped;
        model.settings.rotation = true;
        model.particles.enable_rotation();
        model.particles.vel[0].x = 0.3;
        model.set_dt(1e-7).unwrap();
        let mut cpu = Simulation::new(model.clone());
        let mut gpu = Simulation::with_gpu(model, ctx.clone());
        let a = run_impact(&mut cpu, 20_000, probe_wall);
        let b = run_impact(&mut gpu, 20_000, probe_wall);
        let spin = |s: &Simulation| s.model.particles.rotation.as_ref().unwrap().ang_vel[0].y;
        let (pa, pb) = (&cpu.model.particles, &gpu.model.particles);
        eprintln!(
            "wall: e {:.5} vs {:.5}; vx {:.5} vs {:.5}; ω {:.3} vs {:.3}",
            a.restitution(),
            b.restitution(),
            pa.vel[0].x,
            pb.vel[0].x,
            spin(&cpu),
            spin(&gpu)
        );
        assert!(rel(b.restitution(), a.restitution()) < 1e-3);
        assert!(rel(pb.vel[0].x, pa.vel[0].x) < 1e-3);
        assert!(rel(spin(&gpu), spin(&cpu)) < 1e-3);

        let mut pair = crate::common::two_spheres(mat, 0.005, 1e-6, 0.5, NormalKind::Hertz);
        pair.settings.tangential = TangentialKind::MindlinDamped;
        pair.settings.rotation = true;
        pair.particles.enable_rotation();
        pair.particles.vel[0].y = 0.2;
        pair.set_dt(1e-7).unwrap();
        let mut cpu = Simulation::new(pair.clone());
        let mut gpu = Simulation::with_gpu(pair, ctx);
        run_impact(&mut cpu, 20_000, crate::common::probe_pair);
        run_impact(&mut gpu, 20_000, crate::common::probe_pair);
        let (pa, pb) = (&cpu.model.particles, &gpu.model.particles);
        let (wa, wb) = (spin_z(&cpu), spin_z(&gpu));
        eprintln!("pair: v0 {:?} vs {:?}; ω {wa:.4} vs {wb:.4}", pa.vel[0], pb.vel[0]);
        assert!((pb.vel[0] - pa.vel[0]).norm() < 1e-3 * pa.vel[0].norm());
        assert!(rel(wb, wa) < 1e-3);
        assert!(wa.abs() > 1.0, "the oblique impact must spin the spheres (ω {wa})");
    }

    fn spin_z(s: &Simulation) -> f64 {
        s.model.particles.rotation.as_ref().unwrap().ang_vel[0].z
    }
}
