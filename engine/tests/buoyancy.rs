//! The water table (the `buoyancy` stage): a submerged column's base force is its buoyant
//! weight Σ(m − ρ_f·V)·g, and the status finds it balanced; lowering the table through it
//! raises the base force by exactly the buoyancy lost (a spherical cap where the level cuts an
//! element); Stokes drag brings a sinking element to its terminal speed. Buoyancy is a force
//! stage before integration, so local damping sees it: a sinking element's velocity follows
//! local damping's exact answer for the net force (m − ρ_f·V)·g, it comes to rest on a floor
//! where the undamped equilibrium is, and a floating element's oscillation decays (energy
//! non-increasing) to the flotation depth.

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::effects::buoyancy::physics::submerged_volume;
use matdem_engine::plan::Stage;
use matdem_engine::state::particles::dof;
use matdem_engine::{Model, Simulation, Vec3, Wall};
use std::f64::consts::PI;

const R: f64 = 1e-3;
const RHO: f64 = 2650.0;
const RHO_F: f64 = 1000.0;
const G: f64 = 9.81;

/// Five elements stacked on a floor, held to the vertical, under gravity, damped.
fn column() -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("sand", RHO, 1e5, 1e7, 0.3)).unwrap();
    for i in 0..5 {
        m.add_particle(Vec3::new(0.0, 0.0, R + 2.0 * R * i as f64), R, k).unwrap();
    }
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1e-6).unwrap()).unwrap();
    let all: Vec<u32> = (0..5).collect();
    m.fix(&all, dof::X | dof::Y, true).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    m.settings.damping = 0.5;
    m.settings.water.density = RHO_F;
    m.set_standard_dt().unwrap();
    m
}

fn settle(sim: &mut Simulation, steps: u64) -> f64 {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
    sim.model.walls[0].normal_force.abs()
}

/// Σ m·g − ρ_f·g·Σ V_sub at the elements' positions now.
fn buoyant_weight(m: &Model, level: f64) -> f64 {
    let p = &m.particles;
    (0..m.len()).map(|i| (p.mass[i] - RHO_F * submerged_volume(p.pos[i].z, p.radius[i], level)) * G).sum()
}

#[test]
fn a_submerged_columns_base_force_is_its_buoyant_weight_and_lowering_the_table_adds_the_lost_buoyancy() {
    let mut sim = Simulation::new(column());
    let dry = settle(&mut sim, 20_000);
    let weight: f64 = sim.model.particles.mass.iter().sum::<f64>() * G;
    assert!(((dry - weight) / weight).abs() < 1e-6, "dry base force {dry} against the weight {weight}");
    assert!(!sim.plan().has(Stage::Buoyancy));

    sim.model.settings.water.level = Some(1.0);
    let wet = settle(&mut sim, 20_000);
    assert!(sim.plan().has(Stage::Buoyancy));
    let v = 4.0 / 3.0 * PI * R.powi(3);
    let expected = 5.0 * (RHO - RHO_F) * v * G;
    assert!(((wet - expected) / expected).abs() < 1e-6, "submerged base force {wet} against {expected}");
    // The force lane carries the buoyancy (every force but gravity): settled, the column is
    // balanced. Without it the unbalanced force would be the buoyancy, ~0.2 of the mean contact force.
    let unbalanced = sim.contact_stats().unbalanced_ratio;
    assert!(unbalanced < 1e-6, "unbalanced ratio {unbalanced} of a settled submerged column");

    // The table falls to the centre of the third element: two and a half elements stay wet.
    let level = sim.model.particles.pos[2].z;
    sim.model.settings.water.level = Some(level);
    let lowered = settle(&mut sim, 20_000);
    let expected = buoyant_weight(&sim.model, level);
    assert!(((lowered - expected) / expected).abs() < 1e-6, "base force {lowered} against {expected}");
    let lost = RHO_F * G * 2.5 * v;
    assert!(
        ((lowered - wet - lost) / lost).abs() < 1e-3,
        "raised by {} against the lost buoyancy {lost}",
        lowered - wet
    );
}

// A free element sinking in a viscous fluid reaches the Stokes terminal speed
// (ρ − ρ_f)·V·g/(6π·μ·r) = 2(ρ − ρ_f)·g·r²/(9μ).
#[test]
fn stokes_drag_gives_the_terminal_speed() {
    let mut m = Model::new();
    let k = m.add_material(material("sand", RHO, 1e5, 1e7, 0.3)).unwrap();
    m.add_particle(Vec3::zeros(), R, k).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    m.settings.water =
        matdem_engine::effects::buoyancy::WaterTable { level: Some(1.0), density: RHO_F, viscosity: 1.0 };
    m.set_dt(1e-5).unwrap();
    let mut sim = Simulation::new(m);
    sim.run(20_000, &RunControl::default(), &mut |_| {}).unwrap();
    let terminal = 2.0 * (RHO - RHO_F) * G * R * R / (9.0 * 1.0);
    let v = -sim.model.particles.vel[0].z;
    assert!(((v - terminal) / terminal).abs() < 1e-3, "speed {v} against {terminal}");
}

/// One element of radius R above a floor (wall stiffness 2·kn), the gap `gap`, gravity, local
/// damping α only, the table at `level`.
fn dropped(alpha: f64, level: f64, gap: f64) -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("sand", RHO, 1e5, 1e7, 0.3)).unwrap();
    m.add_particle(Vec3::new(0.0, 0.0, R + gap), R, k).unwrap();
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1e-6).unwrap()).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    m.settings.local_damping = alpha;
    m.settings.water =
        matdem_engine::effects::buoyancy::WaterTable { level: Some(level), density: RHO_F, viscosity: 0.0 };
    m.set_standard_dt().unwrap();
    m
}

/// The height z where the floor's spring k·(R − z) carries the buoyant weight
/// (m − ρ_f·V_sub(z))·g: the undamped equilibrium (bisection; the right side falls with z).
fn resting_height(m: &Model, level: f64) -> f64 {
    let (mass, kw) = (m.particles.mass[0], 2.0 * m.materials[0].kn);
    let excess = |z: f64| kw * (R - z) - (mass - RHO_F * submerged_volume(z, R, level)) * G;
    let (mut lo, mut hi) = (R - 2.0 * mass * G / kw, R);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if excess(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

// Local damping sees the buoyancy. A fully submerged element sinks under the constant net force
// F = (m − ρ_f·V)·g; local damping −α·|F|·sign(v) scales its acceleration by 1 − α·sign(F·v),
// and the leapfrog's first kick starts from v = 0 (sign 0: undamped), so exactly
//   v_n = (F/m)·dt·(1 + (n − 1)·(1 − α)),   z_n = z_0 − dt·Σ_{k≤n} v_k,
// checked to 1e-12 of v_n over 100 steps (before the floor). Were local damping blind to the
// buoyancy b = −ρ_f·V·g/m the velocity would gain (g·(1 − α) + b)·dt a step instead, 0.40 of
// the exact gain here. On the
// floor it comes to rest where the undamped spring carries the buoyant weight, to 1e-6 of
// the overlap, fully submerged and with the table at its centre (a cap), and the floor
// carries the buoyant weight to 1e-6.
#[test]
fn local_damping_sees_buoyancy_a_sinking_element_follows_the_exact_damped_motion_and_rests_at_equilibrium() {
    let alpha = 0.5;
    let mut sim = Simulation::new(dropped(alpha, 1.0, 1e-7));
    let (dt, z0) = (sim.model.clock.dt, sim.model.particles.pos[0].z);
    let v = 4.0 / 3.0 * PI * R.powi(3);
    let mass = sim.model.particles.mass[0];
    let a0 = (mass - RHO_F * v) * G / mass;
    let mut z = z0;
    for n in 1..=100u32 {
        sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
        let exact = -a0 * dt * (1.0 + f64::from(n - 1) * (1.0 - alpha));
        z += exact * dt;
        let p = &sim.model.particles;
        assert!(p.pos[0].z > R, "still falling at step {n}");
        assert!(((p.vel[0].z - exact) / exact).abs() < 1e-12, "step {n}: v {} against {exact}", p.vel[0].z);
        assert!((p.pos[0].z - z).abs() < 1e-12 * (z0 - z), "step {n}: z {} against {z}", p.pos[0].z);
    }
    for level in [1.0, R] {
        let mut sim = Simulation::new(dropped(alpha, level, 1e-7));
        sim.run(50_000, &RunControl::default(), &mut |_| {}).unwrap();
        let m = &sim.model;
        let z_eq = resting_height(m, level);
        let (z, overlap) = (m.particles.pos[0].z, R - z_eq);
        assert!((z - z_eq).abs() < 1e-6 * overlap, "table at {level}: rests at {z}, the equilibrium is {z_eq}");
        let weight = (mass - RHO_F * submerged_volume(z_eq, R, level)) * G;
        let base = m.walls[0].normal_force.abs();
        assert!(((base - weight) / weight).abs() < 1e-6, "table at {level}: floor carries {base} against {weight}");
        if level == R {
            assert!(weight > (mass - RHO_F * v) * G && weight < (mass - 0.5 * RHO_F * v) * G * 1.001);
        }
    }
}

// A floating element (ρ_s = ρ_f/2, no contacts) let go above its flotation depth oscillates
// about it under gravity and buoyancy with local damping (α = 0.5) only. Its energy
// E = ½·m·v_{n−½}·v_{n+½} + m·g·z + U_b(z), U_b = ρ_f·g·π·(r·h³/3 − h⁴/12) (h the submerged
// height; −dU_b/dz is the buoyant force), the leapfrog's own energy, never rises by more than
// 1e-6 of the initial oscillation energy from step to step, falls below 1e-12 of it, and the
// element settles at the flotation depth (ρ_f·V_sub = m: the centre at the level) within
// 1e-9 of r. Were local damping blind to the buoyancy it would resist with α·m·g, a Coulomb
// friction with a dead band of ±α·m·g/k = ±3.3 mm about the depth.
#[test]
fn a_floating_element_with_local_damping_settles_at_the_flotation_depth_and_its_energy_never_rises() {
    let (r, rho_s, level) = (0.01, 0.5 * RHO_F, 0.0);
    let mut m = Model::new();
    let k = m.add_material(material("wood", rho_s, 1e5, 1e7, 0.3)).unwrap();
    m.add_particle(Vec3::new(0.0, 0.0, level + 0.4 * r), r, k).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    m.settings.local_damping = 0.5;
    m.settings.water =
        matdem_engine::effects::buoyancy::WaterTable { level: Some(level), density: RHO_F, viscosity: 0.0 };
    m.set_dt(1e-4).unwrap();
    let mass = m.particles.mass[0];
    let potential = |z: f64| {
        let h = (level - (z - r)).clamp(0.0, 2.0 * r);
        mass * G * z + RHO_F * G * PI * (r * h.powi(3) / 3.0 - h.powi(4) / 12.0)
    };
    // The flotation depth: half the sphere under water, the centre at the level.
    let (z_f, e_f) = (level, potential(level));
    let mut sim = Simulation::new(m);
    let (mut z_prev, mut v_prev) = (sim.model.particles.pos[0].z, 0.0);
    let e0 = potential(z_prev) - e_f;
    let mut e_last = f64::INFINITY;
    // ω = √(3·ρ_f·g/(4·ρ_s·r)) ≈ 38 rad/s: 40 000 steps are about 25 periods.
    for n in 0..40_000 {
        sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
        let p = &sim.model.particles;
        let (z, v) = (p.pos[0].z, p.vel[0].z);
        if n > 0 {
            let e = 0.5 * mass * v_prev * v + potential(z_prev) - e_f;
            assert!(e <= e_last + 1e-6 * e0, "step {n}: energy {e} rose from {e_last} (initially {e0})");
            e_last = e;
        }
        (z_prev, v_prev) = (z, v);
    }
    eprintln!("oscillation energy left {e_last} of {e0}");
    assert!(e_last.abs() < 1e-12 * e0, "oscillation energy left {e_last} of {e0}");
    let z = sim.model.particles.pos[0].z;
    assert!((z - z_f).abs() < 1e-9 * r, "floats at {z}, the flotation depth is {z_f}");
}
