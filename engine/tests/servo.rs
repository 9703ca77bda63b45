//! Servo-controlled walls (`WallMotion::Servo`, `Wall::advance` and its WGSL twin in
//! walls.wgsl) with the contact dashpot on. A move of Δx in one step changes the wall's load by
//! Σk·Δx through its contacts' springs and by Σc·Δx/dt through their dashpots at once; with
//! a strongly damped material (restitution 0.1: Σc/dt ≈ 10·Σk at MatDEM's standard step) a
//! gain from Σk alone overshoots and the platen's stress swings far from its target. With the
//! gain from Σk + Σc/dt the platen holds its target within 1 % at every step, on the CPU and on
//! the GPU (lavapipe in CI; skipped without an adapter unless MATDEM_REQUIRE_GPU=1).

use crate::common::run;
use matdem_engine::builder::{BoxSpec, Container, SizeClass};
use matdem_engine::{Material, Model, Simulation, Vec3, WallMotion, WallShape};

const TARGET: f64 = 100e3;

/// ~250 grains (r 0.2–0.3 mm) in a 3 mm square box, settled under 100 g (their weight is
/// 2 % of the platen's load), then the top platen placed on the highest grain and
/// servo-controlled to 100 kPa; `restitution` sets the contact dashpot.
fn servo_box(restitution: f64) -> Simulation {
    let mut m = Model::new();
    let mut sand = Material::from_micro("sand", 2650.0, 2e5, 1e5, 0.0, 0.0, 0.5, 0.25e-3).unwrap();
    sand.restitution = restitution;
    m.add_material(sand).unwrap();
    let spec = BoxSpec {
        container: Container::Cuboid { width: 3e-3, length: 3e-3 },
        height: 3e-3,
        classes: vec![SizeClass { r_min: 0.2e-3, r_max: 0.3e-3, mass_ratio: 1.0 }],
        target_porosity: 0.4,
        seed: 7,
        top_platen: true,
    };
    spec.build_into(&mut m).unwrap();
    m.set_standard_dt().unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -981.0);
    let mut sim = Simulation::new(m);
    // The fall (only the dashpots dissipate: local damping would slow it), then the settling.
    run(&mut sim, 40_000).unwrap();
    sim.model.settings.local_damping = 0.7;
    run(&mut sim, 10_000).unwrap();
    let m = &mut sim.model;
    let top = (0..m.len()).map(|i| m.particles.pos[i].z + m.particles.radius[i]).fold(0.0, f64::max);
    let dt = m.clock.dt;
    let platen = m.wall_mut("top_platen").unwrap();
    platen.shape = WallShape::Plane { point: Vec3::new(0.0, 0.0, top), normal: -Vec3::z() };
    platen.motion = WallMotion::Servo { stress: TARGET, max_speed: 2e-3 * 0.25e-3 / dt };
    sim
}

/// The largest relative error of the platen's stress over `steps` single steps.
fn worst_error(sim: &mut Simulation, steps: u64) -> f64 {
    let top = sim.model.wall_index("top_platen").unwrap();
    let mut worst = 0.0f64;
    for _ in 0..steps {
        run(sim, 1).unwrap();
        worst = worst.max((sim.model.walls[top].stress() / TARGET - 1.0).abs());
    }
    worst
}

#[test]
fn servo_platen_holds_its_stress_within_one_percent_with_a_strong_dashpot() {
    let mut sim = servo_box(0.1);
    // Load the settled packing to the target, then hold it.
    run(&mut sim, 30_000).unwrap();
    let top = sim.model.wall_index("top_platen").unwrap();
    let w = &sim.model.walls[top];
    let ratio = w.damping / (w.stiffness * sim.model.clock.dt);
    println!(
        "contacts {}, Σk {:.3e} N/m, Σc/dt {:.3e} N/m (×{ratio:.1})",
        w.contacts,
        w.stiffness,
        w.damping / sim.model.clock.dt
    );
    assert!(w.contacts >= 1, "the platen should rest on the packing, {} contacts", w.contacts);
    assert!(ratio > 3.0, "the scene must have a dashpot that matters: Σc/dt = {ratio:.2}·Σk");
    let worst = worst_error(&mut sim, 2_000);
    println!("cpu: worst platen stress error over 2000 steps {:.3} %", 100.0 * worst);
    assert!(worst < 0.01, "platen stress off its target by {:.2} %", 100.0 * worst);
}

#[cfg(feature = "gpu")]
#[test]
fn gpu_servo_platen_holds_its_stress_within_one_percent_with_a_strong_dashpot() {
    let Some(ctx) = crate::common::gpu("gpu_servo") else { return };
    // Packed on the CPU (fast), held on the GPU: the WGSL servo's gain is what is tested.
    let mut cpu = servo_box(0.1);
    run(&mut cpu, 30_000).unwrap();
    let mut gpu = Simulation::with_gpu(cpu.model.clone(), ctx);
    run(&mut gpu, 500).unwrap();
    let top = gpu.model.wall_index("top_platen").unwrap();
    let w = &gpu.model.walls[top];
    let ratio = w.damping / (w.stiffness * gpu.model.clock.dt);
    assert!(ratio > 3.0, "the GPU reports Σc/dt = {ratio:.2}·Σk: the dashpot lane is lost");
    // A run's wall loads come back at its end: sample in chunks of 10 steps.
    let mut worst = 0.0f64;
    for _ in 0..100 {
        run(&mut gpu, 10).unwrap();
        worst = worst.max((gpu.model.walls[top].stress() / TARGET - 1.0).abs());
    }
    println!("gpu: worst platen stress error over 100 samples {:.3} %", 100.0 * worst);
    assert!(worst < 0.01, "GPU platen stress off its target by {:.2} %", 100.0 * worst);
}
