//! The water table (the `buoyancy` stage): a submerged column's base force is its buoyant
//! weight Σ(m − ρ_f·V)·g; lowering the table through it raises the base force by exactly the
//! buoyancy lost (a spherical cap where the level cuts an element); Stokes drag brings a
//! sinking element to its terminal speed.

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::physics::buoyancy::submerged_volume;
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
    m.settings.water = matdem_engine::fields::WaterTable { level: Some(1.0), density: RHO_F, viscosity: 1.0 };
    m.set_dt(1e-5).unwrap();
    let mut sim = Simulation::new(m);
    sim.run(20_000, &RunControl::default(), &mut |_| {}).unwrap();
    let terminal = 2.0 * (RHO - RHO_F) * G * R * R / (9.0 * 1.0);
    let v = -sim.model.particles.vel[0].z;
    assert!(((v - terminal) / terminal).abs() < 1e-3, "speed {v} against {terminal}");
}
