//! The field stages on the GPU (WGSL, f32) against the CPU (f64): conduction in a chain with
//! fixed ends (also in a field step of several mechanical steps and sub-steps), conduction
//! with thermal expansion in a heated bonded bar, and the water table's buoyancy on a
//! column and, with drag under local damping, on free elements. Skipped without an adapter
//! unless MATDEM_REQUIRE_GPU=1 (CI: lavapipe).
#![cfg(feature = "gpu")]

use crate::common::{gpu, material};
use matdem_engine::backend::RunControl;
use matdem_engine::effects::conduction::{ThermalMode, ThermalProps};
use matdem_engine::plan::Stage;
use matdem_engine::state::particles::dof;
use matdem_engine::{Model, Simulation, Vec3, Wall};

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

/// 11 bonded elements on the x axis, held in place, ends at 0 and 1, λ = H/C = 1 s⁻¹.
fn chain(every: u32, substeps: u32) -> Model {
    let r = 0.5;
    let mut m = Model::new();
    let k = m.add_material(material("rod", 1000.0, 1.0, 1.0, 0.0)).unwrap();
    for i in 0..11 {
        m.add_particle(Vec3::new(2.0 * r * i as f64, 0.0, 0.0), r, k).unwrap();
    }
    m.connect(None, 1e-9).unwrap();
    let all: Vec<u32> = (0..11).collect();
    m.fix(&all, dof::ALL, true).unwrap();
    m.settings.heat.reference = 0.0;
    m.settings.heat.every = every;
    m.settings.heat.substeps = substeps;
    m.enable_heat();
    m.set_thermal_material("rod", ThermalProps { conductivity: 2.0, specific_heat: 1.0, expansion: 0.0 }).unwrap();
    m.particles.thermal.capacity.fill(2.0 * r);
    m.groups.set("cold", vec![0]);
    m.groups.set("hot", vec![10]);
    m.set_thermal_mode("cold", ThermalMode::Fixed(Some(0.0))).unwrap();
    m.set_thermal_mode("hot", ThermalMode::Fixed(Some(1.0))).unwrap();
    m.clock.dt = 0.1;
    m
}

// Temperatures after 5 s agree to 2e-6 (f32 round-off over 50 forward-Euler steps), also with
// a field step of 4 mechanical steps in 2 sub-steps; the conductance lane comes back too.
#[test]
fn conduction_in_a_chain_matches_the_cpu() {
    let Some(ctx) = gpu("conduction_chain") else { return };
    for (every, substeps) in [(1, 1), (4, 2)] {
        let mut cpu = Simulation::new(chain(every, substeps));
        let mut gpu = Simulation::with_gpu(chain(every, substeps), ctx.clone());
        run(&mut cpu, 50);
        run(&mut gpu, 50);
        assert!(gpu.plan().has(Stage::Conduction));
        let (a, b) = (&cpu.model.particles.thermal, &gpu.model.particles.thermal);
        for i in 0..11 {
            assert!(
                (a.temperature[i] - b.temperature[i]).abs() < 2e-6,
                "every {every}: node {i}: {} against {}",
                b.temperature[i],
                a.temperature[i]
            );
            assert!((a.conductance[i] - b.conductance[i]).abs() < 1e-6 * a.conductance[i].max(1.0));
        }
        assert!(a.temperature[5] > 0.0);
    }
}

/// A free bonded bar of 10 steel elements whose first element is held 100 K above T0: heat
/// flows along it (a source adds more at the other end) and the elements expand.
fn heated_bar() -> Model {
    let (r, n) = (1e-3, 10usize);
    let mut m = Model::new();
    // Strong bonds, so that the bar stays bonded as it expands.
    let mut steel = material("steel", 7800.0, 1e5, 1e7, 0.3);
    (steel.xb, steel.fs0) = (1e-4, 1e3);
    let k = m.add_material(steel).unwrap();
    for i in 0..n {
        m.add_particle(Vec3::new(2.0 * r * i as f64, 0.0, 0.0), r, k).unwrap();
    }
    m.connect(None, 1e-9).unwrap();
    m.settings.heat.reference = 20.0;
    m.settings.damping = 0.3;
    m.enable_heat();
    m.set_thermal_material("steel", ThermalProps { conductivity: 50.0, specific_heat: 500.0, expansion: 1.2e-5 })
        .unwrap();
    m.groups.set("hot", vec![0]);
    m.groups.set("heater", vec![n as u32 - 1]);
    m.set_thermal_mode("hot", ThermalMode::Fixed(Some(120.0))).unwrap();
    m.set_heat_source("heater", 0.5).unwrap();
    m.set_standard_dt().unwrap();
    m.settings.heat.every = 10;
    m
}

// Temperatures agree to 1e-4 K, radii to 1e-9 of themselves and the bar's length to 1e-6 of
// its change, after 3000 steps of conduction, sources and expansion.
#[test]
fn conduction_with_expansion_in_a_bonded_bar_matches_the_cpu() {
    let Some(ctx) = gpu("conduction_expansion") else { return };
    let mut cpu = Simulation::new(heated_bar());
    let mut gpu = Simulation::with_gpu(heated_bar(), ctx);
    let l0 = cpu.model.particles.pos[9].x - cpu.model.particles.pos[0].x;
    run(&mut cpu, 3000);
    run(&mut gpu, 3000);
    assert!(cpu.plan().conduction.unwrap().expansion);
    let (a, b) = (&cpu.model.particles, &gpu.model.particles);
    eprintln!(
        "cpu {:?}\ngpu {:?}\ncpu r {:?}\ngpu r {:?}",
        a.thermal.temperature, b.thermal.temperature, a.radius, b.radius
    );
    for i in 0..10 {
        let (ta, tb) = (a.thermal.temperature[i], b.thermal.temperature[i]);
        assert!((ta - tb).abs() < 1e-4, "element {i}: {tb} against {ta}");
        assert!(((a.radius[i] - b.radius[i]) / a.radius[i]).abs() < 1e-6, "radius {i}");
    }
    assert!(a.thermal.temperature[1] > 20.5 && a.radius[1] > 1e-3);
    let (la, lb) = (a.pos[9].x - a.pos[0].x, b.pos[9].x - b.pos[0].x);
    assert!(la > l0 && ((la - lb) / (la - l0)).abs() < 0.02, "length change {} against {}", lb - l0, la - l0);
}

/// Five elements on a floor, held to the vertical, the table at the third element's centre.
fn column() -> Model {
    let r = 1e-3;
    let mut m = Model::new();
    let k = m.add_material(material("sand", 2650.0, 1e5, 1e7, 0.3)).unwrap();
    for i in 0..5 {
        m.add_particle(Vec3::new(0.0, 0.0, r + 2.0 * r * i as f64), r, k).unwrap();
    }
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1e-6).unwrap()).unwrap();
    let all: Vec<u32> = (0..5).collect();
    m.fix(&all, dof::X | dof::Y, true).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m.settings.damping = 0.5;
    m.settings.water.level = Some(5.0 * r);
    m.settings.water.viscosity = 1e-3;
    m.set_standard_dt().unwrap();
    m
}

// The base force and the heights agree to f32 round-off (1e-5 relative) once settled, and
// mid-way through the settling (velocities under buoyancy and drag) to 1e-4.
#[test]
fn buoyancy_on_a_column_matches_the_cpu() {
    let Some(ctx) = gpu("buoyancy_column") else { return };
    let mut cpu = Simulation::new(column());
    let mut gpu = Simulation::with_gpu(column(), ctx);
    for (steps, tol) in [(300u64, 1e-4), (20_000, 1e-5)] {
        run(&mut cpu, steps);
        run(&mut gpu, steps);
        assert!(gpu.plan().has(Stage::Buoyancy));
        for i in 0..5 {
            let (za, zb) = (cpu.model.particles.pos[i].z, gpu.model.particles.pos[i].z);
            assert!(((za - zb) / za).abs() < tol, "after {steps}: element {i} at {zb} against {za}");
        }
    }
    let (fa, fb) = (cpu.model.walls[0].normal_force, gpu.model.walls[0].normal_force);
    // The base force is a wall overlap of ~4e-9 m, resolved in f32 against coordinates of 1e-3 m.
    assert!(((fa - fb) / fa).abs() < 5e-3, "base force {fb} against {fa}");
}

/// Four free elements far apart (no contacts) with local damping α = 0.3 and a viscous fluid
/// (μ = 1 Pa·s): sand grains of 1 mm fully and partly under the table (drag x = dt/τ ≈ 0.17,
/// the kernel's closed form) and 1 cm elements of wood (floating) and sand (sinking; x ≈ 1e-3
/// and 2e-3, its series).
fn free_elements() -> Model {
    let mut m = Model::new();
    // Soft springs (no contact forms): the guard's critical step stays above dt.
    let sand = m.add_material(material("sand", 2650.0, 1.0, 1e7, 0.3)).unwrap();
    let wood = m.add_material(material("wood", 500.0, 1.0, 1e7, 0.3)).unwrap();
    for (k, (r, mat, z)) in
        [(1e-3, sand, -0.01), (1e-3, sand, 0.5e-3), (1e-2, wood, 4e-3), (1e-2, sand, -0.05)].into_iter().enumerate()
    {
        m.add_particle(Vec3::new(0.1 * k as f64, 0.0, z), r, mat).unwrap();
    }
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m.settings.local_damping = 0.3;
    m.settings.water =
        matdem_engine::effects::buoyancy::WaterTable { level: Some(0.0), density: 1000.0, viscosity: 1.0 };
    m.set_dt(1e-4).unwrap();
    m
}

// Buoyancy and drag in the force lane, under local damping: velocities agree to 1e-5 of the
// largest speed and heights to 1e-6 of the radius after 50 and 500 steps (f32 against f64).
// A killed element's lane stays empty.
#[test]
fn buoyancy_and_drag_under_local_damping_match_the_cpu() {
    let Some(ctx) = gpu("buoyancy_local_damping") else { return };
    let mut cpu = Simulation::new(free_elements());
    let mut gpu = Simulation::with_gpu(free_elements(), ctx);
    for steps in [50u64, 450] {
        run(&mut cpu, steps);
        run(&mut gpu, steps);
        let (a, b) = (&cpu.model.particles, &gpu.model.particles);
        let top = a.vel.iter().map(|v| v.norm()).fold(0.0, f64::max);
        for i in 0..4 {
            let (dv, dz) = ((a.vel[i] - b.vel[i]).norm(), (a.pos[i].z - b.pos[i].z).abs());
            eprintln!("element {i}: v {:.6e} against {:.6e}, dz {dz:.3e}", b.vel[i].z, a.vel[i].z);
            assert!(dv < 1e-5 * top, "element {i}: velocity {} against {}", b.vel[i].z, a.vel[i].z);
            assert!(dz < 1e-6 * a.radius[i], "element {i}: height {} against {}", b.pos[i].z, a.pos[i].z);
        }
        // Every element moves down: the wood, let go less than half under, sinks towards its
        // flotation depth; the sand sinks.
        assert!(a.vel[2].z < 0.0 && a.vel[0].z < 0.0 && a.vel[3].z < 0.0);
    }
    // A killed element is out of the model: no buoyancy in its force lane, on either backend.
    for sim in [&mut cpu, &mut gpu] {
        sim.model.kill(&[0]).unwrap();
        run(sim, 10);
        assert_eq!(sim.model.particles.force[0], Vec3::zeros());
        assert!(sim.model.particles.force[3].z > 0.0, "a live element's lane carries its buoyancy");
    }
}
