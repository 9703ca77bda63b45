//! Fixed rotational degrees of freedom (`dof::RX`, `RY`, `RZ`; scripts' `d.fix(g, "ry")`) on a
//! solid sphere (r = 1 cm, 2650 kg/m³, linear springs kn = 1e5 N/m, ks = 5e4 N/m, μ = 0.3, e = 1)
//! launched along +x at v0 = 0.5 m/s without spin on a rigid plane wall, rotation on:
//!
//! - its rotation fixed, it slides to rest under kinetic friction: a = μ·g, stopping after
//!   v0/(μ·g) = 0.16988 s and v0²/(2μ·g) = 42.47 mm;
//! - free, friction spins it up until it rolls, at 5/7·v0 (angular momentum about the contact
//!   point is conserved: m·v0·r = (m + I/r²)·v), after 2·v0/(7μ·g);
//!
//! on the CPU and, on lavapipe, the GPU (the WGSL integrate honours the same bits).

use crate::common::{material, rel};
use matdem_engine::backend::RunControl;
use matdem_engine::state::particles::dof;
use matdem_engine::{Model, NormalKind, Simulation, Vec3, Wall};

const R: f64 = 0.01;
const G: f64 = 9.81;
const MU: f64 = 0.3;
const V0: f64 = 0.5;

fn sphere(fixed: u8) -> Model {
    let mut mat = material("ball", 2650.0, 1e5, 1e9, 0.2);
    mat.ks = 5e4;
    mat.mu_p = MU;
    let mut m = Model::new();
    m.settings.normal = NormalKind::Linear;
    let k = m.add_material(mat).unwrap();
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
    let mass = 2650.0 * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    // At its equilibrium overlap against the wall's spring, 2·kn.
    let a = m.add_particle(Vec3::new(0.0, 0.0, R - mass * G / 2e5), R, k).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    m.settings.rotation = true;
    m.particles.enable_rotation();
    m.particles.vel[a] = Vec3::new(V0, 0.0, 0.0);
    m.fix(&[a as u32], fixed, true).unwrap();
    m.set_standard_dt().unwrap();
    m
}

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

/// Slides the sphere until `until` s: the time vx first reached 0 (interpolated between samples
/// 10 steps apart), the distance travelled, and the final vx and ωy·r.
fn slide(mut sim: Simulation, until: f64) -> (Option<f64>, f64, f64, f64) {
    let dt = sim.model.clock.dt;
    let (mut stop, mut last) = (None, (0.0, V0));
    while sim.model.clock.time < until {
        run(&mut sim, 10);
        let (t, v) = (sim.model.clock.time - 0.5 * dt, sim.model.particles.vel[0].x);
        if stop.is_none() && v <= 0.0 {
            stop = Some(last.0 + (t - last.0) * last.1 / (last.1 - v));
        }
        last = (t, v);
    }
    let p = &sim.model.particles;
    let spin = p.rotation.as_ref().unwrap().ang_vel[0];
    (stop, p.pos[0].x, p.vel[0].x, spin.y * R)
}

fn check(sim: impl Fn(Model) -> Simulation, label: &str) {
    let a = MU * G;
    let (stop, distance, v, spin) = slide(sim(sphere(dof::ROTATION)), 1.3 * V0 / a);
    let stop = stop.expect("the sphere stopped");
    eprintln!(
        "{label}, rotation fixed: stop {stop:.5} s ({:.5}), distance {distance:.6} m ({:.6}), spin·r {spin:e}",
        V0 / a,
        V0 * V0 / (2.0 * a)
    );
    assert!(rel(stop, V0 / a) < 0.01, "stopping time");
    assert!(rel(distance, V0 * V0 / (2.0 * a)) < 0.01, "stopping distance");
    assert_eq!(spin, 0.0, "a fixed rotation stays as it was");
    // At rest but for the shear spring's elastic vibration (μ·m·g/ks·√(ks/m) ≈ 1 mm/s).
    assert!(v.abs() < 0.01 * V0);

    // Only ry fixed: the same slide (friction's torque is about y).
    let (stop_y, ..) = slide(sim(sphere(dof::RY)), 1.3 * V0 / a);
    assert!(rel(stop_y.unwrap(), stop) < 1e-3, "{label}: ry alone");

    let (stop, _, v, spin) = slide(sim(sphere(0)), 3.0 * 2.0 * V0 / (7.0 * a));
    eprintln!("{label}, free: rolls at {v:.5} m/s (5/7·v0 = {:.5}), ωy·r {spin:.5}", 5.0 / 7.0 * V0);
    assert!(stop.is_none());
    assert!(rel(v, 5.0 / 7.0 * V0) < 0.01 && rel(spin, v) < 0.01, "rolls at 5/7·v0");
}

#[test]
fn a_sphere_with_rotation_fixed_slides_to_rest_and_a_free_one_rolls_at_five_sevenths() {
    check(Simulation::new, "cpu");
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_fixed_rotation_slides_and_free_rotation_rolls() {
    let Some(ctx) = crate::common::gpu("gpu_fixed_rotation") else { return };
    check(|m| Simulation::with_gpu(m, ctx.clone()), "gpu");
}
