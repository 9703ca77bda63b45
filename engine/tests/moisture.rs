//! Moisture (the `moisture` stage) against exact answers: the chain tests heat passes, with
//! water content (reference/physics.md §4: the steady profile, the published transient at
//! t = 10 s, forward Euler's own discrete form), Σ m·ω conserved with sealed ends, a drying
//! element and a drying layer losing water at the rate evaporation sets, a free element
//! shrinking by its table and bonds taking their share of strength from theirs, the guard's
//! refusal, the plan's lanes, and (with an adapter) the GPU against the CPU.

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::effects::moisture::physics::{evaporation_conductance, pair_moisture_conductance};
use matdem_engine::effects::moisture::WaterMode;
use matdem_engine::plan::{Stage, StepPlan};
use matdem_engine::state::particles::dof;
use matdem_engine::{Error, Model, Simulation, Vec3};
use std::f64::consts::PI;

/// Chain nodes 0…N.
const N: usize = 10;
const R: f64 = 0.5;

/// N + 1 bonded, touching elements on the x axis, held in place, moisture on, ω = 0, and a
/// diffusivity that makes λ = G/m the one asked for. Returns the model and G.
fn chain(lambda: f64, dt: f64) -> (Model, f64) {
    let mut m = Model::new();
    // Soft and heavy, so that the mechanical critical step is far above any dt used here.
    let k = m.add_material(material("soil", 1000.0, 1.0, 1.0, 0.0)).unwrap();
    for i in 0..=N {
        m.add_particle(Vec3::new(2.0 * R * i as f64, 0.0, 0.0), R, k).unwrap();
    }
    m.connect(None, 1e-9).unwrap();
    let all: Vec<u32> = (0..=N as u32).collect();
    m.fix(&all, dof::ALL, true).unwrap();
    m.enable_moisture();
    // A bond's neck of 0.5·R: G = α·π·(R/2)² for α = 1.
    let g1 = pair_moisture_conductance(1.0, 1.0, R, R, 2.0 * R, true, m.effects.moisture.settings.bond_radius);
    assert!((g1 - PI * R * R / 4.0).abs() < 1e-15);
    let mass = m.particles.mass[0];
    m.set_moisture_material("soil", lambda * mass / g1).unwrap();
    m.clock.dt = dt;
    let g = pair_moisture_conductance(lambda * mass / g1, lambda * mass / g1, R, R, 2.0 * R, true, 0.5);
    (m, g)
}

fn fix_ends(m: &mut Model) {
    m.groups.set("dry", vec![0]);
    m.groups.set("wet", vec![N as u32]);
    m.set_water_mode("dry", WaterMode::Fixed(Some(0.0))).unwrap();
    m.set_water_mode("wet", WaterMode::Fixed(Some(1.0))).unwrap();
}

fn run(m: Model, steps: u64) -> Model {
    let mut sim = Simulation::new(m);
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
    sim.model
}

/// The chain's water contents after `n` steps of `dt` from ω = 0 inside, ω(0) = 0, ω(N) = 1:
/// ω_i = i/N + Σ_k b_k·sin(kπi/N)·decay(λ_k), λ_k = 4λ·sin²(kπ/2N).
fn series(lambda: f64, decay: impl Fn(f64) -> f64) -> Vec<f64> {
    let nf = N as f64;
    (0..=N)
        .map(|i| {
            let mut t = i as f64 / nf;
            for k in 1..N {
                let kf = k as f64;
                let b: f64 =
                    (0..=N).map(|j| -(j as f64 / nf) * (kf * PI * j as f64 / nf).sin()).sum::<f64>() * 2.0 / nf;
                let lk = 4.0 * lambda * (kf * PI / (2.0 * nf)).sin().powi(2);
                t += b * (kf * PI * i as f64 / nf).sin() * decay(lk);
            }
            t
        })
        .collect()
}

// Ends held at 0 and 1: the steady profile is linear, ω_i = i/N (the limit m/ΣG is 0.5 s).
#[test]
fn a_chain_with_fixed_water_ends_settles_to_the_exact_linear_profile() {
    let (mut m, _) = chain(1.0, 0.4);
    fix_ends(&mut m);
    let m = run(m, 3000);
    for (i, w) in m.effects.moisture.lanes.water.iter().enumerate() {
        assert!((w - i as f64 / N as f64).abs() < 1e-12, "node {i}: {w}");
    }
}

// The published transient at t = 10 s (λ = 1 s⁻¹), within 1e-4 with a step of 1 ms.
#[test]
fn the_water_chains_transient_at_ten_seconds_matches_the_series_solution() {
    let expected = [0.0, 0.030618, 0.066931, 0.114481, 0.178379, 0.262821, 0.370443, 0.501640, 0.654090, 0.822682, 1.0];
    let (mut m, _) = chain(1.0, 1e-3);
    fix_ends(&mut m);
    let m = run(m, 10_000);
    assert!((m.clock.time - 10.0).abs() < 1e-9);
    for (i, (w, e)) in m.effects.moisture.lanes.water.iter().zip(&expected).enumerate() {
        assert!((w - e).abs() < 1e-4, "node {i}: {w} against {e}");
    }
}

// At a large step (0.4 s) the answer is forward Euler's own, to round-off; also as field
// steps of 4 mechanical steps in 4 sub-steps.
#[test]
fn at_a_large_step_the_water_chain_follows_forward_eulers_exact_discrete_form() {
    let dt = 0.4;
    for (every, substeps, steps) in [(1u32, 1u32, 25u64), (4, 4, 24)] {
        let (mut m, _) = chain(1.0, dt);
        fix_ends(&mut m);
        m.effects.moisture.settings.every = every;
        m.effects.moisture.settings.substeps = substeps;
        let m = run(m, steps);
        let discrete = series(1.0, |lk| (1.0 - dt * lk).powi(steps as i32));
        for (i, (w, e)) in m.effects.moisture.lanes.water.iter().zip(&discrete).enumerate() {
            assert!((w - e).abs() < 1e-12, "every {every}: node {i}: {w} against {e}");
        }
    }
}

// Sealed ends exchange nothing: the ends keep their water exactly and Σ m·ω of the whole chain
// is conserved to round-off while the interior evens out at its own mean.
#[test]
fn sealed_ends_conserve_the_water_to_round_off() {
    let (mut m, _) = chain(1.0, 0.2);
    let w0: Vec<f64> = (0..=N).map(|i| 0.05 + 0.01 * ((i * 7) % 5) as f64).collect();
    m.set_water(&w0).unwrap();
    m.groups.set("ends", vec![0, N as u32]);
    m.set_water_mode("ends", WaterMode::Sealed).unwrap();
    let total0 = m.total_water();
    let m = run(m, 10_000);
    let total = m.total_water();
    assert!(((total - total0) / total0).abs() < 1e-13, "{total} against {total0}");
    let w = &m.effects.moisture.lanes.water;
    assert_eq!((w[0], w[N]), (w0[0], w0[N]));
    let mean = w0[1..N].iter().sum::<f64>() / (N - 1) as f64;
    for x in &w[1..N] {
        assert!((x - mean).abs() < 1e-9, "{x} against {mean}");
    }
}

// One free element drying towards ω_a with E = χ·π·r²: forward Euler's
// ω_n = ω_a + (ω0 − ω_a)·(1 − Δt·E/m)^n to round-off, and exp(−E·t/m) within 1e-4 of the
// initial deficit at Δt·E/m = 1e-4 (forward Euler's error there is about 2e-5 of it at t = m/E).
#[test]
fn a_drying_element_loses_water_at_the_rate_its_evaporation_sets() {
    let mut m = Model::new();
    // So soft that the mechanical critical step is far above the long steps used here.
    let k = m.add_material(material("soil", 2000.0, 1e-9, 1.0, 0.0)).unwrap();
    let r = 0.01;
    m.add_particle(Vec3::zeros(), r, k).unwrap();
    m.fix(&[0], dof::ALL, true).unwrap();
    m.effects.moisture.settings.initial = 0.3;
    m.enable_moisture();
    m.groups.set("surface", vec![0]);
    let (chi, ambient) = (0.05, 0.02);
    m.set_evaporation("surface", chi, ambient).unwrap();
    let rate = evaporation_conductance(chi, r) / m.particles.mass[0];
    let dt = 1e-4 / rate;
    m.clock.dt = dt;
    let m = run(m, 10_000);
    let w = m.effects.moisture.lanes.water[0];
    let discrete = ambient + (0.3 - ambient) * (1.0 - dt * rate).powi(10_000);
    assert!((w - discrete).abs() < 1e-12, "{w} against {discrete}");
    let exact = ambient + (0.3 - ambient) * (-rate * 10_000.0 * dt).exp();
    assert!((w - exact).abs() < 1e-4 * (0.3 - ambient), "{w} against {exact}");
}

// A bonded layer of 11 elements drying from its top element only: each step the layer
// loses exactly what the top's boundary condition sets, E·(ω_top − ω_a)·Δt (to round-off),
// and with diffusion far faster than evaporation (E/Σm = 1e-4 s⁻¹ against the slowest
// diffusion mode's 0.08 s⁻¹: a Biot number of 0.01) the layer dries as one element would,
// ω̄ − ω_a = (ω0 − ω_a)·exp(−E·t/Σm), within 1 % of the deficit at t = Σm/E.
#[test]
fn a_drying_layer_loses_water_at_the_rate_its_boundary_condition_sets() {
    let dt = 0.25;
    let (mut m, _) = chain(1.0, dt);
    m.set_water(&[0.3; N + 1]).unwrap();
    m.groups.set("top", vec![N as u32]);
    let ambient = 0.05;
    let total_mass: f64 = m.particles.mass.iter().sum();
    let chi = 1e-4 * total_mass / (PI * R * R);
    m.set_evaporation("top", chi, ambient).unwrap();
    let e = evaporation_conductance(chi, R);
    let mut sim = Simulation::new(m);
    for _ in 0..200 {
        let before = sim.model.total_water();
        let top = sim.model.effects.moisture.lanes.water[N];
        sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
        let lost = before - sim.model.total_water();
        let set = e * (top - ambient) * dt;
        assert!((lost - set).abs() < 1e-12 * before, "lost {lost} against {set}");
    }
    sim.run(39_800, &RunControl::default(), &mut |_| {}).unwrap();
    let t = sim.model.clock.time;
    let mean = sim.model.total_water() / total_mass;
    let lumped = ambient + (0.3 - ambient) * (-e * t / total_mass).exp();
    assert!(((mean - lumped) / (lumped - ambient)).abs() < 0.01, "mean {mean} against {lumped} at t = {t}");
    assert!(mean < 0.16, "the layer has dried: {mean}");
}

// A free element with the table [(0, 0.9), (0.3, 1.0)]: at ω = 0.15 its radius is 0.95·r0,
// dried to ω = 0 it is 0.9·r0 (mass kept); a radius set by hand is the new r0.
#[test]
fn a_free_element_shrinks_by_the_tables_amount() {
    let mut m = Model::new();
    let k = m.add_material(material("soil", 2000.0, 1.0, 1.0, 0.0)).unwrap();
    let r0 = 0.01;
    m.add_particle(Vec3::zeros(), r0, k).unwrap();
    m.effects.moisture.settings.initial = 0.3;
    m.enable_moisture();
    m.set_radius_table(Some(vec![(0.0, 0.9), (0.3, 1.0)])).unwrap();
    let mass = m.particles.mass[0];
    m.clock.dt = 1e-3;
    m.set_water(&[0.15]).unwrap();
    let mut sim = Simulation::new(m);
    sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
    assert!((sim.model.particles.radius[0] - 0.95 * r0).abs() < 1e-15 * r0, "{}", sim.model.particles.radius[0]);
    assert_eq!(sim.model.particles.mass[0], mass);
    sim.model.groups.set("all", vec![0]);
    sim.model.set_evaporation("all", 1e3, 0.0).unwrap();
    sim.run(2000, &RunControl::default(), &mut |_| {}).unwrap();
    let w = sim.model.effects.moisture.lanes.water[0];
    assert!(w < 1e-9, "dried: {w}");
    assert!((sim.model.particles.radius[0] - 0.9 * r0).abs() < 1e-9 * r0);
    // The plan shows it.
    let plan = sim.plan().to_string();
    assert!(plan.contains("moisture(forward euler") && plan.contains("drying shrinkage"), "{plan}");
    assert!(plan.contains("radius0"), "{plan}");
}

// Bonds take the table's share of their pair's strength at the pair's mean water content.
#[test]
fn bonds_take_their_share_of_strength_from_the_water_content() {
    let (mut m, _) = chain(1.0, 0.01);
    let w0: Vec<f64> = (0..=N).map(|i| 0.02 * i as f64).collect();
    m.set_water(&w0).unwrap();
    m.set_strength_table(Some(vec![(0.0, 1.0), (0.3, 0.4)])).unwrap();
    let m = run(m, 1);
    let c = &m.contacts;
    let w = &m.effects.moisture.lanes.water;
    for i in 0..N {
        let e = c.find(i, i as u32 + 1).unwrap();
        let f = c.find(i + 1, i as u32).unwrap();
        assert_eq!(c.state[e].weakened, c.state[f].weakened, "the two copies of pair {i}");
        let s = 1.0 - 2.0 * (0.5 * (w[i] + w[i + 1]));
        assert!((c.state[e].strength() - s).abs() <= 1.0 / 65535.0, "pair {i}: {} against {s}", c.state[e].strength());
    }
}

// A field step above m/ΣG is refused before the run, naming the element and the fix.
#[test]
fn a_moisture_step_above_the_stability_limit_is_refused_with_the_fix() {
    let (mut m, _) = chain(1.0, 0.6);
    fix_ends(&mut m);
    let mut sim = Simulation::new(m);
    let e = sim.run(10, &RunControl::default(), &mut |_| {}).unwrap_err();
    let Error::InvalidScene(msg) = &e else { panic!("{e}") };
    assert!(
        msg.contains("element 1") && msg.contains("5.000e-1 s") && msg.contains("d.moisture_substeps to 2"),
        "{msg}"
    );
    sim.model.effects.moisture.settings.substeps = 2;
    sim.run(10, &RunControl::default(), &mut |_| {}).unwrap();
}

// Without moisture: no stage, no lane; with it the plan lists the stage and its lanes, and
// the bytes the model holds are the plan's account.
#[test]
fn moisture_lanes_exist_only_when_the_scene_enables_it() {
    let mut m = Model::new();
    let k = m.add_material(material("soil", 1000.0, 1.0, 1.0, 0.0)).unwrap();
    for i in 0..4 {
        m.add_particle(Vec3::new(i as f64, 0.0, 0.0), 0.5, k).unwrap();
    }
    m.clock.dt = 1e-3;
    let plan = StepPlan::build(&m);
    assert!(!plan.has(Stage::Moisture) && plan.to_string().contains("moisture"));
    let m = run(m, 2);
    assert_eq!(m.effects.moisture.lanes.bytes(), 0);
    let mut m = m;
    m.enable_moisture();
    let plan = StepPlan::build(&m);
    assert!(plan.has(Stage::Moisture));
    let set = plan.lane_sets().into_iter().find(|s| s.stage == "moisture").unwrap();
    assert_eq!(set.lanes, ["water", "diffusivity", "transfer", "ambient", "conductance", "mode"]);
    assert_eq!(m.effects.moisture.lanes.bytes(), 4 * set.bytes_per_particle);
    // A particle added later gets its lanes too, at the initial water content.
    m.effects.moisture.settings.initial = 0.2;
    m.add_particle(Vec3::new(9.0, 0.0, 0.0), 0.5, k).unwrap();
    assert_eq!(m.effects.moisture.lanes.water[4], 0.2);
    assert!(m.effects.moisture.lanes.consistent(5));
}

// A drying chain saved mid-way and loaded continues bit for bit (format 7 carries the
// moisture settings, tables and lanes).
#[test]
fn a_drying_model_continues_bitwise_after_a_checkpoint() {
    use matdem_engine::checkpoint::{decode, encode};
    let scene = || {
        let (mut m, _) = chain(1.0, 0.05);
        m.materials[0].xb = 1.0;
        m.materials[0].fs0 = 1e3;
        m.set_water(&[0.3; N + 1]).unwrap();
        m.groups.set("top", vec![N as u32]);
        m.set_evaporation("top", 50.0, 0.02).unwrap();
        m.set_radius_table(Some(vec![(0.0, 0.97), (0.3, 1.0)])).unwrap();
        m.set_strength_table(Some(vec![(0.0, 1.0), (0.3, 0.5)])).unwrap();
        m.effects.moisture.settings.every = 2;
        m
    };
    let mut straight = Simulation::new(scene());
    straight.run(300, &RunControl::default(), &mut |_| {}).unwrap();
    let bytes = encode(&straight.model, b"");
    straight.run(300, &RunControl::default(), &mut |_| {}).unwrap();
    let loaded = decode(&bytes).unwrap().model;
    assert!(loaded.effects.moisture.settings.enabled && loaded.effects.moisture.settings.radius_table.is_some());
    let mut resumed = Simulation::new(loaded);
    resumed.run(300, &RunControl::default(), &mut |_| {}).unwrap();
    let (a, b) = (&straight.model.particles, &resumed.model.particles);
    let (wa, wb) = (&straight.model.effects.moisture.lanes, &resumed.model.effects.moisture.lanes);
    assert!(wa.water[N] < 0.3 && a.radius[N] < R);
    assert_eq!(wa, wb);
    assert_eq!(a.radius, b.radius);
    assert!(encode(&straight.model, b"") == encode(&resumed.model, b""));
}

// Thermal expansion and drying shrinkage together: r = r0·f(ω)·(1 + α·(T − T0)). A free
// element with the table [(0, 0.9), (0.3, 1.0)] at ω = 0.15 (f = 0.95) heated by 100 K
// (α = 1e-5) has 0.95·1.001·r0 within round-off (1e-15 of r0), whichever field stepped last
// (heat every 3 steps, water every 2); cooled to +50 K it has 0.95·1.0005·r0, dried to ω = 0
// 0.9·1.0005·r0; the mass is kept; the plan names both.
#[test]
fn a_free_element_with_expansion_and_shrinkage_changes_radius_by_the_product() {
    let mut m = Model::new();
    let k = m.add_material(material("soil", 2000.0, 1.0, 1.0, 0.0)).unwrap();
    let r0 = 0.01;
    m.add_particle(Vec3::zeros(), r0, k).unwrap();
    m.effects.moisture.settings.initial = 0.15;
    m.effects.moisture.settings.every = 2;
    m.enable_moisture();
    m.set_radius_table(Some(vec![(0.0, 0.9), (0.3, 1.0)])).unwrap();
    m.settings.heat.reference = 20.0;
    m.settings.heat.every = 3;
    m.enable_heat();
    let props =
        matdem_engine::effects::conduction::ThermalProps { conductivity: 1.0, specific_heat: 800.0, expansion: 1e-5 };
    m.set_thermal_material("soil", props).unwrap();
    m.set_temperatures(&[120.0]).unwrap();
    let mass = m.particles.mass[0];
    m.clock.dt = 1e-3;
    let mut sim = Simulation::new(m);
    let radius = |sim: &Simulation| sim.model.particles.radius[0];
    for steps in 1..=12 {
        sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
        // Once both fields have stepped (steps 2 and 3), the radius is the product.
        if steps >= 3 {
            let want = r0 * 0.95 * (1.0 + 1e-5 * 100.0);
            assert!((radius(&sim) - want).abs() < 1e-15 * r0, "step {steps}: {} against {want}", radius(&sim));
        }
    }
    sim.model.set_temperatures(&[70.0]).unwrap();
    sim.run(3, &RunControl::default(), &mut |_| {}).unwrap();
    let want = r0 * 0.95 * (1.0 + 1e-5 * 50.0);
    assert!((radius(&sim) - want).abs() < 1e-15 * r0, "cooled: {} against {want}", radius(&sim));
    sim.model.set_water(&[0.0]).unwrap();
    sim.run(2, &RunControl::default(), &mut |_| {}).unwrap();
    let want = r0 * 0.9 * (1.0 + 1e-5 * 50.0);
    assert!((radius(&sim) - want).abs() < 1e-15 * r0, "dried: {} against {want}", radius(&sim));
    assert_eq!(sim.model.particles.mass[0], mass);
    let plan = sim.plan().to_string();
    assert!(plan.contains("drying shrinkage × thermal expansion") && plan.contains("thermal expansion)"), "{plan}");
}

// A free bonded bar of 10 touching elements at ω = 0.15 with the table [(0, 0.98), (0.3, 1)]
// (f = 0.99) heated uniformly by ΔT = 100 K (α = 1.2e-5): its bonds pull and push the changed
// elements until they touch again, so its length (centre to centre plus the end radii) changes
// by 0.99·(1 + 1.2e-3) − 1 = −8.81e-3 of itself, within 1 % of that change.
#[test]
fn a_bonded_bars_length_changes_by_the_product_of_both_factors() {
    let (r, n) = (1e-3, 10usize);
    let mut m = Model::new();
    let mut steel = material("steel", 7800.0, 1e5, 1e7, 0.3);
    (steel.xb, steel.fs0) = (1e-3, 1e3);
    let k = m.add_material(steel).unwrap();
    for i in 0..n {
        m.add_particle(Vec3::new(2.0 * r * i as f64, 0.0, 0.0), r, k).unwrap();
    }
    m.connect(None, 1e-9).unwrap();
    let length =
        |m: &Model| m.particles.pos[n - 1].x - m.particles.pos[0].x + m.particles.radius[0] + m.particles.radius[n - 1];
    let l0 = length(&m);
    m.effects.moisture.settings.initial = 0.15;
    m.enable_moisture();
    m.set_radius_table(Some(vec![(0.0, 0.98), (0.3, 1.0)])).unwrap();
    m.settings.heat.reference = 20.0;
    m.enable_heat();
    let props = matdem_engine::effects::conduction::ThermalProps {
        conductivity: 50.0,
        specific_heat: 500.0,
        expansion: 1.2e-5,
    };
    m.set_thermal_material("steel", props).unwrap();
    m.set_temperatures(&vec![120.0; n]).unwrap();
    m.settings.damping = 0.3;
    m.set_standard_dt().unwrap();
    let m = run(m, 20_000);
    let want = 0.99 * (1.0 + 1.2e-3) - 1.0;
    let strain = (length(&m) - l0) / l0;
    assert!(((strain - want) / want).abs() < 0.01, "strain {strain} against {want}");
    assert!(m.breakages.is_empty(), "no bond broke: {:?}", m.breakages);
}

#[cfg(feature = "gpu")]
mod gpu {
    use super::*;
    use crate::common::gpu;

    /// The chain with fixed ends, evaporation from node 7, a shrinkage and a strength table.
    fn scene(every: u32, substeps: u32) -> Model {
        let (mut m, _) = chain(1.0, 0.1);
        // Bonds that hold while the elements shrink (the chain's material has no strength).
        m.materials[0].xb = 1.0;
        m.materials[0].fs0 = 1e3;
        fix_ends(&mut m);
        m.effects.moisture.settings.every = every;
        m.effects.moisture.settings.substeps = substeps;
        m.groups.set("surface", vec![7]);
        m.set_evaporation("surface", 0.5, 0.1).unwrap();
        m.set_radius_table(Some(vec![(0.0, 0.98), (1.0, 1.0)])).unwrap();
        m.set_strength_table(Some(vec![(0.0, 1.0), (1.0, 0.5)])).unwrap();
        m
    }

    // Both fields set the radius (heat every 2 steps, water every 3, so either may step
    // last): radii and the expansion's r0 after 50 steps agree to 1e-6 of themselves, and are
    // the product of the two factors.
    #[test]
    fn expansion_with_shrinkage_on_the_gpu_matches_the_cpu() {
        let Some(ctx) = gpu("moisture_expansion_chain") else { return };
        let scene = || {
            let mut m = scene(3, 1);
            m.settings.heat.every = 2;
            m.enable_heat();
            let props = matdem_engine::effects::conduction::ThermalProps {
                conductivity: 0.5,
                specific_heat: 1.0,
                expansion: 1e-3,
            };
            m.set_thermal_material("soil", props).unwrap();
            let t0 = m.settings.heat.reference;
            let t: Vec<f64> = (0..=N).map(|i| t0 + 10.0 * i as f64).collect();
            m.set_temperatures(&t).unwrap();
            m
        };
        let mut cpu = Simulation::new(scene());
        let mut gpu = Simulation::with_gpu(scene(), ctx);
        cpu.run(50, &RunControl::default(), &mut |_| {}).unwrap();
        gpu.run(50, &RunControl::default(), &mut |_| {}).unwrap();
        assert!(gpu.plan().to_string().contains("drying shrinkage × thermal expansion"), "{}", gpu.plan());
        let (a, b) = (&cpu.model.particles, &gpu.model.particles);
        let wa = &cpu.model.effects.moisture.lanes;
        let t0 = cpu.model.settings.heat.reference;
        let table = cpu.model.effects.moisture.settings.radius_table.clone().unwrap();
        for i in 0..=N {
            assert!(
                ((a.radius[i] - b.radius[i]) / a.radius[i]).abs() < 1e-6,
                "radius {i}: {} against {}",
                b.radius[i],
                a.radius[i]
            );
            let (ra, rb) = (a.thermal.radius0[i], b.thermal.radius0[i]);
            assert!(((ra - rb) / ra).abs() < 1e-6, "expansion's r0 {i}: {rb} against {ra}");
            // The CPU's radius is the product, to round-off: the water last stepped at step 48,
            // the heat at step 50, each with the other's factor.
            let product = wa.radius0[i] * table.at(wa.water[i]) * (1.0 + 1e-3 * (a.thermal.temperature[i] - t0));
            assert!(((a.radius[i] - product) / product).abs() < 1e-12, "radius {i}: {} against {product}", a.radius[i]);
        }
        assert!(a.radius[N] > a.radius[1], "the hot end is larger: {:?}", a.radius);
    }

    // Water contents after 5 s agree to 2e-6 (f32 over 50 forward-Euler steps), radii to
    // 1e-6 of themselves, bond shares to 2/65535, on both field-step settings.
    #[test]
    fn moisture_on_the_gpu_matches_the_cpu() {
        let Some(ctx) = gpu("moisture_chain") else { return };
        for (every, substeps) in [(1, 1), (4, 2)] {
            let mut cpu = Simulation::new(scene(every, substeps));
            let mut gpu = Simulation::with_gpu(scene(every, substeps), ctx.clone());
            cpu.run(50, &RunControl::default(), &mut |_| {}).unwrap();
            gpu.run(50, &RunControl::default(), &mut |_| {}).unwrap();
            assert!(gpu.plan().has(Stage::Moisture));
            let (a, b) = (&cpu.model.particles, &gpu.model.particles);
            let (la, lb) = (&cpu.model.effects.moisture.lanes, &gpu.model.effects.moisture.lanes);
            for i in 0..=N {
                let (wa, wb) = (la.water[i], lb.water[i]);
                assert!((wa - wb).abs() < 2e-6, "every {every}: node {i}: {wb} against {wa}");
                let (ga, gb) = (la.conductance[i], lb.conductance[i]);
                assert!((ga - gb).abs() < 1e-5 * ga.max(1e-30), "conductance {i}: {gb} against {ga}");
                assert!(((a.radius[i] - b.radius[i]) / a.radius[i]).abs() < 1e-6, "radius {i}");
            }
            assert!(la.water[5] > 0.0 && a.radius[3] < R, "{:?} {:?}", la.water, a.radius);
            let (ca, cb) = (&cpu.model.contacts, &gpu.model.contacts);
            for i in 0..N {
                let sa = ca.state[ca.find(i, i as u32 + 1).unwrap()].strength();
                let sb = cb.state[cb.find(i, i as u32 + 1).unwrap()].strength();
                assert!((sa - sb).abs() <= 2.0 / 65535.0, "bond {i}: {sb} against {sa}");
                assert!(sa < 1.0 || i == 0);
            }
        }
    }
}
