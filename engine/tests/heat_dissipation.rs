//! The dissipated heat fed into temperature (`d.heat_dissipation`, the conduction stage's
//! `feed`): the heat the ledger books on an element (damping, contact damping, friction,
//! breakage; not wall work) raises that element's temperature by heat/C at the next field step.
//! On the CPU exactly: without conduction each element's C·(T − T0) is its booked heat, with
//! conduction between insulated elements Σ C·(T − T0) is the total booked heat, and a
//! fixed-temperature element keeps its temperature. On the GPU (lavapipe) against the CPU.

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::effects::conduction::{ThermalMode, ThermalProps};
use matdem_engine::{Model, Simulation, Vec3};

const N: usize = 6;

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

/// A free bonded bar of six 1 mm sand elements on the x axis, vibrating (every other element
/// moving at ±1 cm/s), damped by viscous (0.1) and local (0.1) damping and contact dashpots
/// (restitution 0.8); heat on, T0 = 0, c = 1e-4 J/(kg·K), so the vibration's 3e-9 J heat the
/// bar by about 1 K; conductivity `k` (through the bonds' necks, H = 2·k·0.5·r and
/// λ = H/C ≈ 9e5·k s⁻¹ per W/(m·K)), a field step every 5 steps.
fn bar(k: f64) -> Model {
    let r = 1e-3;
    let mut m = Model::new();
    let mut sand = material("sand", 2650.0, 1e5, 1e7, 0.3);
    (sand.xb, sand.fs0, sand.restitution) = (1e-4, 1e3, 0.8);
    let id = m.add_material(sand).unwrap();
    for i in 0..N {
        m.add_particle(Vec3::new(2.0 * r * i as f64, 0.0, 0.0), r, id).unwrap();
        m.particles.vel[i] = Vec3::new(if i % 2 == 0 { 0.01 } else { -0.01 }, 0.0, 0.0);
    }
    m.connect(None, 1e-9).unwrap();
    m.settings.damping = 0.1;
    m.settings.local_damping = 0.1;
    m.settings.heat.reference = 0.0;
    m.settings.heat.every = 5;
    m.settings.heat.dissipation = true;
    m.enable_heat();
    m.set_thermal_material("sand", ThermalProps { conductivity: k, specific_heat: 1e-4, expansion: 0.0 }).unwrap();
    m.set_standard_dt().unwrap();
    m
}

fn heat_content(m: &Model) -> Vec<f64> {
    let th = &m.particles.thermal;
    (0..m.len()).map(|i| th.capacity[i] * (th.temperature[i] - m.settings.heat.reference)).collect()
}

// Without conduction each element's C·(T − T0) is the heat its ledger booked, to 1e-12 of
// it, after 2000 steps (a multiple of the field step); with conduction (λ ≈ 9e3 s⁻¹, the heat
// spreads along the bar) the sum Σ C·(T − T0) is the total booked heat to 1e-12, and most of
// the vibration's energy has become heat; a fixed-temperature element keeps its temperature.
#[test]
fn the_booked_heat_becomes_temperature_element_by_element_and_in_total() {
    let mut sim = Simulation::new(bar(0.0));
    let e0: f64 = sim.model.particles.mass.iter().map(|m| 0.5 * m * 1e-4).sum();
    run(&mut sim, 2000);
    let m = &sim.model;
    assert!(sim.model.particles.heat.contact_damping.iter().any(|&h| h > 0.0), "the dashpots booked heat");
    for (i, q) in heat_content(m).into_iter().enumerate() {
        let booked = m.booked_heat(i);
        assert!(booked > 0.0 && ((q - booked) / booked).abs() < 1e-12, "element {i}: C·ΔT {q} against booked {booked}");
    }

    let mut sim = Simulation::new(bar(0.01));
    run(&mut sim, 2000);
    let m = &sim.model;
    let q: f64 = heat_content(m).iter().sum();
    let booked: f64 = (0..N).map(|i| m.booked_heat(i)).sum();
    assert!(((q - booked) / booked).abs() < 1e-12, "Σ C·ΔT {q} against booked {booked}");
    // Local damping books α·|F|·|v0|·dt, with the half-step velocity: within a few % of the work.
    assert!(booked > 0.5 * e0 && booked < 1.05 * e0, "booked {booked} of the vibration's {e0}");
    // Conduction moved heat: the elements' contents differ from what each booked.
    assert!((0..N).any(|i| (heat_content(m)[i] - m.booked_heat(i)).abs() > 1e-3 * booked));

    let mut model = bar(0.01);
    model.groups.set("held", vec![0]);
    model.set_thermal_mode("held", ThermalMode::Fixed(Some(0.0))).unwrap();
    let mut sim = Simulation::new(model);
    run(&mut sim, 2000);
    assert_eq!(sim.model.particles.thermal.temperature[0], 0.0);
    assert!(sim.model.particles.thermal.temperature[1] > 0.0);
}

// The GPU feeds the device's ledger as the CPU feeds its own. Without conduction each
// element's C·(T − T0) is the heat the device booked on it to 1e-5 (f32 temperatures summing
// ~400 field steps' increments; measured 7e-7), after 1003 + 997 steps: two runs, so the model goes back to
// the host and up again in between with heat booked and not yet fed (1003 is not a multiple of
// the field step); the model's `fed` lane then is its booked heat to 1e-10 (compensated f32
// pairs; measured 2e-14), at a field-step boundary, so a run may continue on either backend. With conduction the temperatures agree
// with the CPU's to 1e-3 of the rise: the ledgers themselves agree to that (the dashpot and
// damping heat of an f32 trajectory, as in gpu_energy.rs; measured 3e-4 here), and Σ C·ΔT is
// the device's booked heat to 1e-5.
#[cfg(feature = "gpu")]
#[test]
fn the_gpu_feeds_the_dissipated_heat_as_the_cpu_does() {
    let Some(ctx) = crate::common::gpu("heat_dissipation") else { return };
    let mut gpu = Simulation::with_gpu(bar(0.0), ctx.clone());
    for steps in [1003u64, 997] {
        run(&mut gpu, steps);
    }
    let m = &gpu.model;
    for (i, q) in heat_content(m).into_iter().enumerate() {
        let booked = m.booked_heat(i);
        assert!(booked > 0.0 && ((q - booked) / booked).abs() < 1e-5, "element {i}: C·ΔT {q} against booked {booked}");
        let fed = m.particles.thermal.fed[i];
        assert!(((fed - booked) / booked).abs() < 1e-10, "element {i}: fed {fed} against booked {booked}");
    }

    let mut cpu = Simulation::new(bar(0.01));
    let mut gpu = Simulation::with_gpu(bar(0.01), ctx);
    for steps in [1003u64, 997] {
        run(&mut cpu, steps);
        run(&mut gpu, steps);
    }
    let (a, b) = (&cpu.model.particles.thermal, &gpu.model.particles.thermal);
    let top = a.temperature.iter().copied().fold(0.0, f64::max);
    assert!(top > 0.1, "heated by {top} K");
    for i in 0..N {
        let (ta, tb) = (a.temperature[i], b.temperature[i]);
        assert!((ta - tb).abs() < 1e-3 * top, "element {i}: {tb} against {ta}");
    }
    let q: f64 = heat_content(&gpu.model).iter().sum();
    let booked: f64 = (0..N).map(|i| gpu.model.booked_heat(i)).sum();
    assert!(((q - booked) / booked).abs() < 1e-5, "Σ C·ΔT {q} against the device's booked {booked}");
}
