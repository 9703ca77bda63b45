//! `--backend auto`'s speed test on the device CI has, Mesa's lavapipe (a software Vulkan
//! device): a small scene steps faster on the CPU backend, and the report carries both
//! figures and the choice. Without an adapter the test prints a note and passes, unless
//! MATDEM_REQUIRE_GPU=1.
#![cfg(feature = "gpu")]

use crate::common::gpu;
use matdem_engine::backend::speed_test::{measure, Choice};
use matdem_engine::bench::LatticeScene;
use matdem_engine::Model;

#[test]
fn on_a_software_gpu_a_small_scene_measures_the_cpu_faster_and_picks_it() {
    let Some(ctx) = gpu("speed_test") else { return };
    assert!(ctx.is_software(), "this test expects lavapipe; on a hardware GPU the choice is the scene's");
    let model = LatticeScene::with_particles(240).build().unwrap();
    let before = (model.clock, model.particles.pos.clone(), model.particles.vel.clone());
    let t = measure(&model, ctx).unwrap();
    eprintln!("{t}");
    let cpu = t.cpu.expect("a model with particles is measured");
    let gpu = t.gpu.as_ref().expect("lavapipe steps the scene");
    assert!(cpu.rate > 0.0 && gpu.rate > 0.0 && cpu.steps > 0 && gpu.steps > 0, "{t:?}");
    assert!(cpu.rate > gpu.rate, "2 CPU cores against software Vulkan on {} particles: {t}", t.particles);
    assert_eq!(t.choice, Choice::Cpu);
    let line = t.to_string();
    assert!(line.contains("particle-steps/s") && line.contains("gpu (llvmpipe") && line.ends_with("→ cpu"), "{line}");
    let after = (model.clock, model.particles.pos.clone(), model.particles.vel.clone());
    assert!(before == after, "the caller's model is not stepped");
}

#[test]
fn an_empty_model_picks_the_cpu_without_measuring_the_gpu() {
    let Some(ctx) = gpu("speed_test_empty") else { return };
    let t = measure(&Model::new(), ctx).unwrap();
    assert_eq!((t.choice, t.cpu, t.particles), (Choice::Cpu, None, 0));
    assert!(t.to_string().contains("nothing to measure → cpu"), "{t}");
}

// How a host moves its models once `auto` has chosen: a simulation that ran on the CPU and
// is moved to the GPU continues from where the CPU left it, and back.
#[test]
fn a_simulation_moved_between_the_cpu_and_the_gpu_continues_from_where_it_was() {
    let Some(ctx) = gpu("speed_test_set_target") else { return };
    let model = LatticeScene::with_particles(64).build().unwrap();
    let mut sim = matdem_engine::Simulation::new(model);
    crate::common::run(&mut sim, 20).unwrap();
    sim.set_target(matdem_engine::backend::Target::Gpu(ctx)).unwrap();
    assert!(sim.backend_name().starts_with("gpu (f32) on"), "{}", sim.backend_name());
    crate::common::run(&mut sim, 20).unwrap();
    sim.set_target(matdem_engine::backend::Target::Cpu).unwrap();
    assert_eq!(sim.backend_name(), "cpu (f64)");
    crate::common::run(&mut sim, 20).unwrap();
    assert_eq!(sim.model.clock.step, 60, "every run stepped the same model");
}
