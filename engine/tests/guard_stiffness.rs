//! The guard against the stiffest current contact (guard.rs, shaders/guard.wgsl): a sphere
//! resting on a floor, Hertz normal law with a shear spring much stiffer than Hertz at the
//! resting overlap. Its wall contact's critical step √(2·m/(2·Ks)) is well under the element's
//! own (the check before a run lets dt through); at every chunk end the guard must see the
//! contact, stop with a message naming it on both backends — or with `GuardMode::Warn` go on —
//! and let a dt under its limit run.

use crate::common::{material, rel, run, sphere_mass};
use matdem_engine::guard::{GuardMode, STIFFNESS_FRACTION};
use matdem_engine::{Error, Model, NormalKind, Simulation, Vec3, Wall};

const R: f64 = 1e-3;
const DENSITY: f64 = 2650.0;
const KS: f64 = 1e6;

/// The sphere 1e-7 m into the floor (about its resting overlap under gravity), at a time step
/// `rate` times its wall contact's critical step.
fn resting_sphere(rate: f64) -> (Model, f64) {
    let mut mat = material("stiff_shear", DENSITY, 1e6, 1e8, 0.0);
    mat.ks = KS;
    let mut m = Model::new();
    m.settings.normal = NormalKind::Hertz;
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    let k = m.add_material(mat).unwrap();
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
    m.add_particle(Vec3::new(0.0, 0.0, R - 1e-7), R, k).unwrap();
    // A rigid wall carries the element's own shear spring, 2·Ks (plan.rs).
    let critical = (2.0 * sphere_mass(DENSITY, R) / (2.0 * KS)).sqrt();
    m.set_dt(rate * critical).unwrap();
    (m, critical)
}

fn check_message(msg: &str, critical: f64) {
    assert!(msg.contains("particle 0 is in the stiffest contact, with wall `floor`"), "names the contact: {msg}");
    assert!(msg.contains("shear spring is 2.000e6 N/m"), "names the stiffness: {msg}");
    assert!(msg.contains(&format!("critical step √(2m/k) of {critical:.3e} s")), "names the critical step: {msg}");
    let limit = STIFFNESS_FRACTION * critical;
    assert!(msg.contains(&format!("Fix: set dt ≤ {limit:.3e} s (d.dt = {limit:.3e})")), "names the fix: {msg}");
    assert!(msg.contains("set_standard_dt()"), "{msg}");
}

#[test]
fn a_contact_too_stiff_for_dt_stops_the_run_and_is_named() {
    let (m, critical) = resting_sphere(0.8);
    // The element's own estimate lets this dt through: only the contact check sees it.
    assert!(m.clock.dt < m.critical_dt().unwrap().1);
    let mut sim = Simulation::new(m);
    let err = run(&mut sim, 300).expect_err("0.8 of the contact's critical step is over the limit");
    match &err {
        Error::Unstable(inst) => {
            assert_eq!(inst.particle, 0);
            assert_eq!(inst.step, 100, "stopped at the first chunk end");
            assert!(rel(inst.critical_dt, critical) < 1e-12);
        }
        other => panic!("expected Error::Unstable, got {other:?}"),
    }
    check_message(&err.to_string(), critical);
}

#[test]
fn under_the_limit_or_in_warn_mode_the_run_goes_on() {
    let (m, _) = resting_sphere(0.6);
    let mut sim = Simulation::new(m);
    run(&mut sim, 300).expect("0.6 of the contact's critical step is under the limit");
    assert!(sim.take_warning().is_none(), "nothing to warn of under the limit");

    let (mut m, critical) = resting_sphere(0.8);
    m.settings.guard = GuardMode::Warn;
    let mut sim = Simulation::new(m);
    run(&mut sim, 300).expect("warn mode warns once and goes on");
    // The warning is the stop's message, held for the host (the engine prints nothing).
    let warning = sim.take_warning().expect("a warning of the too-stiff contact").to_string();
    check_message(&warning, critical);
    assert!(sim.take_warning().is_none(), "taken once");
    run(&mut sim, 300).expect("and does not stop later either");
    assert!(sim.take_warning().is_none(), "given once per model");
    assert_eq!(sim.model.clock.step, 600);
}

#[cfg(feature = "gpu")]
#[test]
fn the_gpu_guard_sees_the_same_contact() {
    let Some(ctx) = crate::common::gpu("gpu_guard_stiffness") else { return };
    let (m, critical) = resting_sphere(0.8);
    let mut cpu = Simulation::new(m.clone());
    let mut gpu = Simulation::with_gpu(m, ctx.clone());
    let a = run(&mut cpu, 300).unwrap_err();
    let b = run(&mut gpu, 300).unwrap_err();
    match (&a, &b) {
        (Error::Unstable(x), Error::Unstable(y)) => {
            assert_eq!((x.step, x.particle), (y.step, y.particle));
            assert!(rel(x.critical_dt, y.critical_dt) < 1e-12);
        }
        other => panic!("expected two Error::Unstable, got {other:?}"),
    }
    check_message(&b.to_string(), critical);

    let (m, _) = resting_sphere(0.6);
    let mut gpu = Simulation::with_gpu(m, ctx);
    run(&mut gpu, 300).expect("under the limit on the GPU too");
    assert_eq!(gpu.model.clock.step, 300);
}
