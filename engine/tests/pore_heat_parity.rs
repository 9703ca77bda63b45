//! The pore fluid's temperature on the GPU (shaders/pore_heat.wgsl, f32) against the CPU (f64):
//! a bonded column with grains at uneven temperatures, hot fluid injected at its bottom and a
//! reservoir at another temperature at its top (pressures, fluid and grain temperatures, the
//! regions' heat); the heat of grains and fluid conserved on the device in a sealed, insulated
//! column compressed by its wall while the network is rebuilt through the host; thermal
//! pressurisation of a sealed rigid block on the device, Δp = K_f·β_f·ΔT. Skipped without an
//! adapter unless MATDEM_REQUIRE_GPU=1 (CI: lavapipe).
#![cfg(feature = "gpu")]

use crate::common::gpu;
use crate::pore_heat::{bonded_column, rigid_block, thermal_energy, warm_fluid, A, T0};
use matdem_engine::backend::RunControl;
use matdem_engine::effects::conduction::{ThermalMode, ThermalProps};
use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, FluidHeat, PoreRegion};
use matdem_engine::physics::Vec3;
use matdem_engine::plan::Stage;
use matdem_engine::{Model, Simulation, WallMotion};

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

fn largest(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(0.0, |a, x| a.max(x.abs()))
}

/// The bonded 3 × 3 × nz column of pore_heat.rs, its grains at uneven temperatures (T0 + 0, 40,
/// …, 160 K), hot fluid (T0 + 60 K) injected at 2e-6 m³/s into the pores its bottom layer bounds,
/// a reservoir at 0 Pa and T0 − 10 K in those its top layer bounds.
fn injected_column(nz: usize) -> Model {
    let nx = 3;
    let mut m = bonded_column(nx, nz);
    m.settings.pores.fluid = Fluid { rebuild_drift: 0.5, ..warm_fluid() };
    for (i, t) in m.particles.thermal.temperature.iter_mut().enumerate() {
        *t = T0 + 40.0 * ((i * 7) % 5) as f64;
    }
    m.enable_pore_flow().unwrap();
    let bottom: Vec<u32> = (0..(nx * nx) as u32).collect();
    let top: Vec<u32> = (((nz - 1) * nx * nx) as u32..(nz * nx * nx) as u32).collect();
    m.add_pore_boundary_at(PoreRegion::Elements(bottom), BoundaryKind::Flux(2e-6), Some(T0 + 60.0)).unwrap();
    m.add_pore_boundary_at(PoreRegion::Elements(top), BoundaryKind::Pressure(0.0), Some(T0 - 10.0)).unwrap();
    m
}

// 300 coupled steps of a 3 × 3 × 6 column (54 bonded elements, 116 pores) with the fluid's
// temperature on: hot injection, a cold reservoir, the exchange with grains at uneven temperatures
// (745 flow and 1 exchange sub-steps a step). Every pore pressure within 5e-3 of the largest
// (measured on lavapipe: 9.8e-4), every fluid and grain temperature within 1e-4 of the largest
// |T − T0| (1.3e-5 and 1.5e-5: 1.6e-3 K and 2.2e-3 K), and the heat the regions booked within
// 1e-4 of the largest (4.6e-6): f32 state against f64 over 2·10⁵ flow sub-steps.
#[test]
fn fluid_temperature_matches_the_cpu() {
    let Some(ctx) = gpu("pore_heat_parity") else { return };
    let nz = 6;
    let mut cpu = Simulation::new(injected_column(nz));
    let mut gpu = Simulation::with_gpu(injected_column(nz), ctx);
    assert!(gpu.plan().has(Stage::PoreFlow) && gpu.plan().pore_flow.is_some_and(|p| p.thermal));
    // The plan's words give each backend's bytes of the network.
    let (on_cpu, on_gpu) = (cpu.plan_text(), gpu.plan_text());
    assert!(on_cpu.contains("pore network (cpu, f64)") && !on_cpu.contains("(gpu, f32)"), "{on_cpu}");
    assert!(on_gpu.contains("pore network (gpu, f32)") && on_gpu.contains("exchange conductance"), "{on_gpu}");
    let steps = 300;
    run(&mut cpu, steps);
    run(&mut gpu, steps);
    let (a, b) = (cpu.model.pores.as_ref().unwrap(), gpu.model.pores.as_ref().unwrap());
    assert_eq!(a.rebuilds, b.rebuilds, "the network was rebuilt a different number of times");
    let p_scale = largest(a.pressure.iter().copied());
    let p_worst = largest(a.pressure.iter().zip(&b.pressure).map(|(p, q)| p - q));
    let t_scale = largest(a.temperature.iter().map(|t| t - T0));
    let t_worst = largest(a.temperature.iter().zip(&b.temperature).map(|(p, q)| p - q));
    let (ta, tb) = (&cpu.model.particles.thermal.temperature, &gpu.model.particles.thermal.temperature);
    let g_scale = largest(ta.iter().map(|t| t - T0));
    let g_worst = largest(ta.iter().zip(tb).map(|(p, q)| p - q));
    let h_worst = largest(a.region_heat.iter().zip(&b.region_heat).map(|(p, q)| p - q));
    let h_scale = largest(a.region_heat.iter().copied());
    println!(
        "{} pores, {steps} steps, {} flow / {} exchange sub-steps (cpu), {} / {} (gpu): pressures apart {p_worst:.3e} \
         Pa of {p_scale:.3e} Pa ({:.2e}); fluid temperatures {t_worst:.3e} K of {t_scale:.3e} K ({:.2e}); grain \
         temperatures {g_worst:.3e} K of {g_scale:.3e} K ({:.2e}); region heat {h_worst:.3e} J of {h_scale:.3e} J ({:.2e})",
        a.pressure.len(),
        a.substeps,
        a.exchange_substeps,
        b.substeps,
        b.exchange_substeps,
        p_worst / p_scale,
        t_worst / t_scale,
        g_worst / g_scale,
        h_worst / h_scale
    );
    // The scene does what it says: pressure from the injection, heat exchanged and booked.
    assert!(p_scale > 1e3, "the injection raised no pore pressure ({p_scale:e} Pa)");
    assert!(a.region_heat[0] > 0.0 && a.region_heat[1] < 0.0, "region heat {:?}", a.region_heat);
    assert!(a.exchange_substeps > 0, "the fluid exchanged no heat with the grains");
    assert!(p_worst < 5e-3 * p_scale, "GPU pore pressures depart {p_worst:e} Pa (scale {p_scale:e} Pa)");
    assert!(t_worst < 1e-4 * t_scale, "GPU fluid temperatures depart {t_worst:e} K (scale {t_scale:e} K)");
    assert!(g_worst < 1e-4 * g_scale, "GPU grain temperatures depart {g_worst:e} K (scale {g_scale:e} K)");
    assert!(h_worst < 1e-4 * h_scale, "GPU region heat departs {h_worst:e} J (scale {h_scale:e} J)");
}

// The CPU test's sealed, insulated column (pore_heat.rs) on the device: grains and fluid at
// uneven temperatures, compressed by the top wall for 1500 steps (669 flow sub-steps a step) while
// the network is rebuilt through the host (rebuild_drift 2e-4 of the mean radius; the CPU's 13
// rebuilds are 24 here, each a little earlier). Σ C·(T − T0) of grains + Σ c_f·m·(T − T0) of fluid
// changes by less than 1e-7 of Σ|C·(T − T0)| (measured on lavapipe: 1.1e-9; the CPU's 2e-15),
// while ~5 % of the fluid's heat moves to the grains: the temperatures and excess masses keep
// their rounding (the carries; without the excess masses' it was 2.8e-6). The grains do not
// conduct here, so that the conduction stage's own f32 updates stay out of the account.
#[test]
fn heat_of_grains_and_fluid_is_conserved_on_the_device() {
    let Some(ctx) = gpu("pore_heat_conservation") else { return };
    let (nx, nz) = (3, 6);
    let mut m = bonded_column(nx, nz);
    m.set_thermal_material("grain", ThermalProps { conductivity: 0.0, specific_heat: 0.8, expansion: 0.0 }).unwrap();
    m.settings.pores.fluid = warm_fluid();
    m.enable_pore_flow().unwrap();
    for (i, t) in m.particles.thermal.temperature.iter_mut().enumerate() {
        *t = T0 + 40.0 * ((i * 7) % 5) as f64;
    }
    let dt = m.clock.dt;
    let mut sim = Simulation::with_gpu(m, ctx);
    run(&mut sim, 1);
    {
        let f = sim.model.pores.as_mut().unwrap();
        for p in (0..f.temperature.len()).step_by(3) {
            f.temperature[p] += 80.0;
        }
    }
    let (g0, f0) = thermal_energy(&sim.model);
    let scale = {
        let th = &sim.model.particles.thermal;
        let f = sim.model.pores.as_ref().unwrap();
        th.capacity.iter().zip(&th.temperature).map(|(c, t)| c * (t - T0).abs()).sum::<f64>()
            + (0..f.mass.len()).map(|p| 4.186 * f.mass[p] * (f.temperature[p] - T0).abs()).sum::<f64>()
    };
    sim.model.wall_mut("top").unwrap().motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -2e-4 * A / (1000.0 * dt)));
    run(&mut sim, 1500);
    let (g1, f1) = thermal_energy(&sim.model);
    let f = sim.model.pores.as_ref().unwrap();
    let drift = ((g1 + f1) - (g0 + f0)).abs() / scale;
    println!(
        "grains {g0:.6e} → {g1:.6e} J, fluid {f0:.6e} → {f1:.6e} J, change of the sum {drift:.2e} of Σ|C·(T − T0)|; \
         {} rebuilds, {} flow and {} exchange sub-step(s) a step",
        f.rebuilds, f.substeps, f.exchange_substeps
    );
    assert!(f.rebuilds > 0, "the network was never rebuilt");
    assert!((f1 - f0).abs() > 0.05 * f0.abs(), "the fluid exchanged almost no heat ({f0:e} → {f1:e} J)");
    assert!(f.pressure.iter().any(|&p| p.abs() > 1.0), "nothing drove the fluid");
    assert!(f.region_heat.iter().all(|&h| h == 0.0), "a sealed column booked heat: {:?}", f.region_heat);
    assert!(drift < 1e-7, "thermal energy changed by {drift:e} of its scale");
}

// Thermal pressurisation on the device: the CPU test's sealed 5³ rigid block, grains held 30 K
// above T0, 600 steps; every pore ends at K_f·β_f·ΔT within 1e-5 of it (measured on lavapipe:
// 2.1e-7; the CPU's is exact), its mass unchanged within 1e-9 (1e-15).
#[test]
fn a_sealed_rigid_sample_heated_on_the_device_rises_by_bulk_modulus_times_expansion_times_dt() {
    let Some(ctx) = gpu("pore_heat_pressurisation") else { return };
    let dtemp = 30.0;
    let mut m = rigid_block(5);
    let heat = FluidHeat { specific_heat: 0.004186, ..FluidHeat::default() };
    m.settings.pores.fluid = Fluid { bulk_modulus: 1e6, viscosity: 1.0, heat, ..warm_fluid() };
    m.enable_pore_flow().unwrap();
    m.set_thermal_mode("all", ThermalMode::Fixed(Some(T0 + dtemp))).unwrap();
    let m0 = m.pores.as_ref().unwrap().total_mass();
    let mut sim = Simulation::with_gpu(m, ctx);
    run(&mut sim, 600);
    let f = sim.model.pores.as_ref().unwrap();
    let want = f.fluid.bulk_modulus * f.fluid.heat.expansion * dtemp;
    let worst = f.pressure.iter().map(|p| (p / want - 1.0).abs()).fold(0.0, f64::max);
    let coolest = f.temperature.iter().fold(f64::MAX, |a, &t| a.min(t));
    let mass = (f.total_mass() / m0 - 1.0).abs();
    println!(
        "K_f·β_f·ΔT = {want:.6e} Pa; pore pressures within {worst:.2e} of it; coolest pore {:.6} K above T0; mass \
         changed by {mass:.2e}; {} pores, {} flow / {} exchange sub-steps",
        coolest - T0,
        f.temperature.len(),
        f.substeps,
        f.exchange_substeps
    );
    assert!(worst < 1e-5, "a pore's pressure is {worst:e} off K_f·β_f·ΔT");
    assert!(mass < 1e-9, "the sealed sample's mass changed by {mass:e}");
}

// The CPU test's hot injection through a rigid block (pore_heat.rs) on the device, with hot fluid
// injected at one end at a rate (Nu = 2, element c = 0.8 J/(kg·K), one run of 1500 steps), or
// held at a pressure and temperature (a well; Nu = 3000, c = 800 J/(kg·K), 15 runs of 100 steps,
// each an upload and a download), drained at the other end. The heat grains and fluid gain is
// what the regions booked within 1e-6 of the injected heat (measured on lavapipe: 7e-9 and
// 3e-8), and the fluid's mass gain what they supplied within 1e-7 of the supplied mass (2.5e-9
// and 2e-10; the excess masses keep their rounding: without that, a steady flow lost the same
// sub-ulp mass every sub-step, 2.5e-3 of the throughput in examples/hot_cold_injection).
#[test]
fn heat_injected_and_drained_on_the_device_is_booked() {
    let Some(ctx) = gpu("pore_heat_booked") else { return };
    for (well, nu, c_s, chunk) in [(false, 2.0, 0.8, 1500), (true, 3000.0, 800.0, 100)] {
        let mut m = rigid_block(5);
        m.set_thermal_material("grain", ThermalProps { conductivity: 3.0, specific_heat: c_s, expansion: 0.0 })
            .unwrap();
        let mut fluid = Fluid { bulk_modulus: 1e6, viscosity: 0.1, ..warm_fluid() };
        fluid.heat.nusselt = nu;
        m.settings.pores.fluid = fluid;
        m.enable_pore_flow().unwrap();
        let big = 1.0;
        let lo = PoreRegion::Box { lo: Vec3::repeat(-big), hi: Vec3::new(big, big, 0.6 * A) };
        let hi = PoreRegion::Box { lo: Vec3::new(-big, -big, 3.4 * A), hi: Vec3::repeat(big) };
        let kind = if well { BoundaryKind::Pressure(2e4) } else { BoundaryKind::Flux(1e-5) };
        m.add_pore_boundary_at(lo, kind, Some(T0 + 50.0)).unwrap();
        m.add_pore_boundary(hi, BoundaryKind::Pressure(0.0)).unwrap();
        let mut sim = Simulation::with_gpu(m, ctx.clone());
        run(&mut sim, 1);
        let (g0, f0) = thermal_energy(&sim.model);
        let f = sim.model.pores.as_ref().unwrap();
        let (b0, s0, m0) = (f.region_heat.iter().sum::<f64>(), f.region_mass.iter().sum::<f64>(), f.total_mass());
        for _ in 0..1500 / chunk {
            run(&mut sim, chunk);
        }
        let (g1, f1) = thermal_energy(&sim.model);
        let f = sim.model.pores.as_ref().unwrap();
        let booked = f.region_heat.iter().sum::<f64>() - b0;
        let gained = (g1 + f1) - (g0 + f0);
        let injected = f.region_heat[0];
        let supplied = f.region_mass.iter().sum::<f64>() - s0;
        let mass_err = ((f.total_mass() - m0) - supplied) / f.region_mass[0];
        println!(
            "{}: injected {injected:.6e} J, drained {:.6e} J, gained {gained:.6e} J (booked {booked:.6e}): {:.2e} of \
             the injected; mass gained against supplied {mass_err:.2e} of the injected mass; {} flow / {} exchange \
             sub-steps",
            if well { "well at 2e4 Pa" } else { "flux" },
            f.region_heat[1],
            (gained - booked) / injected,
            f.substeps,
            f.exchange_substeps
        );
        assert!(g1 > g0 && injected > 0.0, "the injected heat did not reach the grains");
        assert!(((gained - booked) / injected).abs() < 1e-6, "gained {gained:e} J vs booked {booked:e} J");
        assert!(mass_err.abs() < 1e-7, "the fluid gained {mass_err:e} of the injected mass more than supplied");
    }
}
