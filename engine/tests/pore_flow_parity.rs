//! The `pore_flow` stage on the GPU (shaders/pore_flow.wgsl, f32) against the CPU (f64): the
//! flow update alone (an uneven start in a simple-cubic column with a reservoir at each end and
//! an injection well; mass conservation with every boundary sealed), and the coupled stage in
//! the GPU backend's step (a bonded, confined column under a step load, drained at its top:
//! pore pressures and positions against the CPU's; a sealed column compressed by its top wall
//! while the network is rebuilt through the host: mass conserved; Terzaghi's consolidation run on
//! the device). Skipped without an adapter
//! unless MATDEM_REQUIRE_GPU=1 (CI: lavapipe).
#![cfg(feature = "gpu")]

use crate::common::{gpu, pore_column};
use matdem_engine::backend::RunControl;
use matdem_engine::effects::pore_flow::gpu::PoreFlowKernel;
use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, PoreBoundary, PoreFlow, PoreRegion};
use matdem_engine::physics::Vec3;
use matdem_engine::plan::Stage;
use matdem_engine::{Material, Model, Simulation, WallMotion};

const A: f64 = 1e-3;

fn column(n: usize, nz: usize) -> Model {
    let mut m = Model::new();
    let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4 * A).unwrap()).unwrap();
    for i in 0..n {
        for j in 0..n {
            for k in 0..nz {
                m.add_particle(Vec3::new(i as f64, j as f64, k as f64) * A, 0.4 * A, mat).unwrap();
            }
        }
    }
    m
}

fn uneven(m: &Model) -> PoreFlow {
    let mut f = PoreFlow::new(m, Fluid { bulk_modulus: 1e6, max_substeps: 1_000_000, ..Fluid::default() }).unwrap();
    for p in (0..f.mass.len()).step_by(5) {
        f.mass[p] *= 1.0 + 1e-3 * (p % 7) as f64;
    }
    f.update_pressure();
    f
}

// 400 sub-steps at 0.9 of the stable step: every pore's pressure within 1e-5 of the largest
// (f32 against f64 over 400 explicit updates).
#[test]
fn flow_update_matches_the_cpu() {
    let Some(ctx) = gpu("pore_flow_parity") else { return };
    let m = column(4, 8);
    let mut cpu = uneven(&m);
    let big = 1.0;
    cpu.set_boundaries(vec![
        PoreBoundary::boxed(Vec3::repeat(-big), Vec3::new(big, big, 0.5 * A), BoundaryKind::Pressure(800.0)),
        PoreBoundary::boxed(Vec3::new(-big, -big, 6.5 * A), Vec3::repeat(big), BoundaryKind::Pressure(0.0)),
        PoreBoundary {
            region: PoreRegion::Point(Vec3::new(1.5, 1.5, 3.5) * A),
            kind: BoundaryKind::Flux(1e-9),
            temperature: None,
        },
    ])
    .unwrap();
    let mut gpu_f = cpu.clone();
    let (_, crit) = cpu.critical_dt();
    let h = 0.9 * crit;
    let n = 400;
    let kernel = PoreFlowKernel::upload(&ctx, &gpu_f, h).unwrap();
    kernel.substeps(&ctx, n);
    kernel.download(&ctx, &mut gpu_f).unwrap();
    for _ in 0..n {
        cpu.substep(h);
    }
    let scale = cpu.pressure.iter().fold(0.0f64, |a, p| a.max(p.abs()));
    let worst = cpu.pressure.iter().zip(&gpu_f.pressure).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    println!("{} pores, {n} sub-steps: largest |p_gpu − p_cpu| = {worst:.3e} Pa of {scale:.3e} Pa", cpu.pressure.len());
    assert!(worst < 1e-5 * scale, "GPU pressures depart {worst:e} Pa (scale {scale:e} Pa)");
}

// Sealed: the fluid's mass on the device is conserved to f32 round-off of the excess masses
// (the total mass to 1e-9 of itself).
#[test]
fn flow_update_conserves_mass_on_the_device() {
    let Some(ctx) = gpu("pore_flow_mass") else { return };
    let m = column(4, 4);
    let mut f = uneven(&m);
    let m0 = f.total_mass();
    let (_, crit) = f.critical_dt();
    let kernel = PoreFlowKernel::upload(&ctx, &f, 0.9 * crit).unwrap();
    kernel.substeps(&ctx, 2000);
    kernel.download(&ctx, &mut f).unwrap();
    let drift = (f.total_mass() - m0).abs() / m0;
    let (lo, hi) = f.pressure.iter().fold((f64::MAX, f64::MIN), |(a, b), &p| (a.min(p), b.max(p)));
    println!("mass drift {drift:.2e}; pressures {lo:.4e} .. {hi:.4e} Pa");
    assert!(drift < 1e-9, "mass changed by {drift:e} of itself");
    assert!(hi - lo < 1e-2 * hi.abs(), "pressure still ranges {lo}..{hi}");
}

/// The confined, bonded column of engine/tests/pore_coupling.rs (nx × nx × nz, kn = 1e6 N/m),
/// its fluid drained through the pores its top layer bounds, under a servo-held top wall
/// (the load the fluid first carries).
fn loaded_column(nx: usize, nz: usize, fluid: Fluid, sigma: f64) -> Model {
    let mut m = pore_column(nx, nz, A, 1e6);
    m.settings.pores.fluid = fluid;
    m.enable_pore_flow().unwrap();
    let top: Vec<u32> = (((nz - 1) * nx * nx) as u32..(nz * nx * nx) as u32).collect();
    m.add_pore_boundary(PoreRegion::Elements(top), BoundaryKind::Pressure(0.0)).unwrap();
    let dt = m.clock.dt;
    m.wall_mut("top").unwrap().motion = WallMotion::Servo { stress: sigma, max_speed: 1e-3 * A / dt };
    m
}

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

// 400 coupled steps of a 3 × 3 × 8 column (72 elements, bonded: the bond checks run) loaded to
// 1 MPa, drained at the top, with a fluid of K_f = 1e9 Pa (16 flow sub-steps a step): every
// pore pressure within 5e-3 of the largest (measured on lavapipe: 1.8e-3, 980 Pa of 5.6e5 Pa),
// and every position within 1e-3 of the largest displacement (measured: 4.4e-4). f32 state
// against f64 over 400 steps of a stiff coupled system: with K_f as stiff as the skeleton a
// pore's pressure moves by K_f·δV/V, so 1e-6 of a pore's volume is 1 kPa.
#[test]
fn coupled_stage_matches_the_cpu() {
    let Some(ctx) = gpu("pore_flow_coupled") else { return };
    let (nx, nz) = (3, 8);
    let fluid = Fluid { bulk_modulus: 1e9, viscosity: 5.0, max_substeps: 200, ..Fluid::default() };
    let mut cpu = Simulation::new(loaded_column(nx, nz, fluid.clone(), 1e6));
    let mut gpu = Simulation::with_gpu(loaded_column(nx, nz, fluid, 1e6), ctx);
    assert!(gpu.plan().has(Stage::PoreFlow));
    let x0 = cpu.model.particles.pos.clone();
    let steps = 400;
    run(&mut cpu, steps);
    run(&mut gpu, steps);
    let (a, b) = (cpu.model.pores.as_ref().unwrap(), gpu.model.pores.as_ref().unwrap());
    assert_eq!(a.rebuilds, b.rebuilds, "the network was rebuilt a different number of times");
    let scale = a.pressure.iter().fold(0.0f64, |s, p| s.max(p.abs()));
    let worst = a.pressure.iter().zip(&b.pressure).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
    let moved = cpu.model.particles.pos.iter().zip(&x0).map(|(x, o)| (x - o).norm()).fold(0.0, f64::max);
    let apart =
        cpu.model.particles.pos.iter().zip(&gpu.model.particles.pos).map(|(x, y)| (x - y).norm()).fold(0.0, f64::max);
    println!(
        "{} pores, {steps} steps, {} sub-steps (cpu) / {} (gpu) in the last: largest |p_gpu − p_cpu| = {worst:.3e} Pa \
         of {scale:.3e} Pa; positions apart by {apart:.3e} m of a largest displacement {moved:.3e} m",
        a.pressure.len(),
        a.substeps,
        b.substeps
    );
    assert!(scale > 1e4, "the load raised no pore pressure ({scale:e} Pa)");
    assert!(worst < 5e-3 * scale, "GPU pore pressures depart {worst:e} Pa (scale {scale:e} Pa)");
    assert!(apart < 1e-3 * moved, "GPU positions depart {apart:e} m (largest displacement {moved:e} m)");
    let ma = a.total_mass();
    assert!((ma - b.total_mass()).abs() < 1e-6 * ma, "fluid mass {} against {ma}", b.total_mass());
}

// A sealed 3 × 3 × 6 column compressed by its top wall, the network rebuilt through the host
// (rebuild_drift 2e-4 of the mean radius): the fluid's mass on the device is conserved to f32
// round-off of the excess masses (each sub-step rounds each pore's excess, ~1e-7 of p/K_f of its
// mass), bounded here by 1e-9 of the total (measured on lavapipe: 9e-11), and the network was
// rebuilt at least once on the way (2 rebuilds).
#[test]
fn coupled_stage_conserves_mass_on_the_device() {
    let Some(ctx) = gpu("pore_flow_coupled_mass") else { return };
    let (nx, nz) = (3, 6);
    let mut m = pore_column(nx, nz, A, 1e6);
    m.settings.pores.fluid =
        Fluid { bulk_modulus: 1e8, viscosity: 1e-2, max_substeps: 10_000, rebuild_drift: 2e-4, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    let dt = m.clock.dt;
    let m0 = m.pores.as_ref().unwrap().total_mass();
    let mut sim = Simulation::with_gpu(m, ctx);
    sim.model.wall_mut("top").unwrap().motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -2e-4 * A / (1000.0 * dt)));
    run(&mut sim, 1500);
    let f = sim.model.pores.as_ref().unwrap();
    let drift = (f.total_mass() - m0).abs() / m0;
    let pmax = f.pressure.iter().fold(0.0f64, |a, &p| a.max(p));
    println!(
        "mass drift {drift:.2e} of itself after 1500 coupled GPU steps, {} rebuilds, max pressure {pmax:.3e} Pa",
        f.rebuilds
    );
    assert!(f.rebuilds > 0, "the network was never rebuilt");
    assert!(pmax > 0.0, "the compression raised no pressure");
    assert!(f.boundary_mass.abs() < 1e-12 * m0, "the sealed boundaries added {:e} kg", f.boundary_mass);
    assert!(drift < 1e-9, "mass changed by {drift:e} of itself");
}

// Terzaghi's consolidation on the device: the column of pore_coupling.rs's CPU test (3 × 3 × 12,
// loaded to 1 MPa through a servo wall, drained at the top), with a fluid as stiff as the
// skeleton (K_f = M, not 10·M: the flow sub-steps a consolidation needs scale with K_f/M + n,
// and lavapipe is slow: 8 a step here) and μ set so that T_v = 1 after 20,000 steps; the excess
// pore pressure at mid-depth against Terzaghi's series (with the fluid's storage in c_v) within
// the CPU test's 10 % at T_v = 0.1, 0.3 and 0.6 (measured on lavapipe: −1.0 %, +2.2 %, +7.3 %),
// and within 2e-3 of u0 of the CPU's run of the same column (measured: 3e-4). The skeleton's
// modulus is measured dry on the CPU (the CPU test's first half).
#[test]
fn terzaghi_consolidation_on_the_device() {
    use crate::pore_coupling::{layer_pressures, settlement, terzaghi, top_layer};
    let Some(ctx) = gpu("pore_flow_terzaghi") else { return };
    let (nx, nz) = (3, 12);
    let sigma = 1e6;
    let hull = ((nx - 1) as f64 * A).powi(2);
    let mut dry = Simulation::new(pore_column(nx, nz, A, 1e6));
    let dt = dry.model.clock.dt;
    dry.model.wall_mut("top").unwrap().motion = WallMotion::Servo { stress: sigma, max_speed: 1e-3 * A / dt };
    run(&mut dry, 20_000);
    let modulus = sigma / (settlement(&dry.model, nx, nz) / ((nz - 1) as f64 * A));

    let mut m = pore_column(nx, nz, A, 1e6);
    let k_f = modulus;
    m.settings.pores.fluid = Fluid { bulk_modulus: k_f, viscosity: 1.0, max_substeps: 200, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    m.add_pore_boundary(PoreRegion::Elements(top_layer(nx, nz)), BoundaryKind::Pressure(0.0)).unwrap();
    let f = m.pores.as_ref().unwrap();
    let bottom: Vec<u32> = (0..(nx * nx) as u32).collect();
    let (q, c_in, c_out) = f.darcy_flux(PoreRegion::Elements(bottom), PoreRegion::Elements(top_layer(nx, nz))).unwrap();
    let k = f.fluid.viscosity * q * (c_out.z - c_in.z) / hull;
    let n = f.porosity(&m.particles.pos);
    let h_drain = (nz as f64 - 1.5) * A;
    let storage = 1.0 / modulus + n / k_f;
    let t_end = 20_000.0 * dt;
    let mu = k * t_end / (storage * h_drain * h_drain);
    m.set_pore_fluid(Fluid { viscosity: mu, ..m.settings.pores.fluid.clone() }).unwrap();
    let cv = k / (mu * storage);
    let u0 = sigma / (1.0 + n * modulus / k_f);
    m.wall_mut("top").unwrap().motion = WallMotion::Servo { stress: sigma, max_speed: 1e-3 * A / dt };
    let mut cpu = Simulation::new(m.clone());
    let mut sim = Simulation::with_gpu(m, ctx);
    let z_mid = (nz as f64 - 1.5) * A - 0.5 * h_drain;
    let mid = |m: &Model| {
        let p = layer_pressures(m, nz);
        let x = z_mid / A - 0.5;
        let (k, w) = (x.floor() as usize, x - x.floor());
        (p[k] * (1.0 - w) + p[k + 1] * w) / u0
    };
    let mut done = 0u64;
    for tv in [0.1, 0.3, 0.6] {
        let steps = (tv * t_end / dt).round() as u64;
        run(&mut sim, steps - done);
        run(&mut cpu, steps - done);
        done = steps;
        let (u, u_cpu) = (mid(&sim.model), mid(&cpu.model));
        let tv_now = cv * sim.model.clock.time / (h_drain * h_drain);
        let want = terzaghi(0.5, tv_now);
        println!(
            "T_v = {tv_now:.3}: u/u0 at mid-depth {u:.4} (gpu), {u_cpu:.4} (cpu) vs Terzaghi {want:.4} ({:+.1} %); {} flow \
             sub-steps a step",
            (u / want - 1.0) * 100.0,
            sim.model.pores.as_ref().unwrap().substeps
        );
        assert!((u / want - 1.0).abs() < 0.10, "T_v = {tv_now:.3}: u/u0 = {u:.4} vs Terzaghi's {want:.4}");
        assert!((u - u_cpu).abs() < 2e-3, "T_v = {tv_now:.3}: u/u0 = {u:.4} on the GPU, {u_cpu:.4} on the CPU");
    }
}

// Cracks on the device: a bonded 3 × 3 × 6 column whose cement narrows its throats to a tenth,
// fluid injected at the bottom and drained at the top, the bonds of its middle layer broken
// after the network's build (their throats lose the cement and gain the cubic law). After 200
// steps the device's conductances (the bond checks of `pore_bonds`, the crack law) are the
// CPU's within 1e-4 of the largest (f32 geometry; measured on lavapipe: 1.8e-5), the 58 cracked
// throats over twice as conductive as the cemented ones (9x), and the pore pressures within 5e-3
// of the largest (measured 1.2e-3: 350 Pa of 2.8e5 Pa).
#[test]
fn broken_bonds_open_their_throats_on_the_device_as_on_the_cpu() {
    let Some(ctx) = gpu("pore_flow_cracks") else { return };
    let (nx, nz) = (3, 6);
    let make = || {
        let mut m = pore_column(nx, nz, A, 1e6);
        m.settings.pores.fluid =
            Fluid { bulk_modulus: 1e8, viscosity: 1.0, cement_factor: 0.1, max_substeps: 200, ..Fluid::default() };
        m.enable_pore_flow().unwrap();
        let top: Vec<u32> = (((nz - 1) * nx * nx) as u32..(nz * nx * nx) as u32).collect();
        m.add_pore_boundary(PoreRegion::Elements(top), BoundaryKind::Pressure(0.0)).unwrap();
        let well = PoreRegion::Point(Vec3::new(1.0, 1.0, 0.5) * A);
        m.add_pore_boundary(well, BoundaryKind::Flux(1e-7)).unwrap();
        let middle: Vec<u32> = ((2 * nx * nx) as u32..(3 * nx * nx) as u32).collect();
        assert!(m.break_bonds(Some(&middle)).unwrap() > 0);
        m
    };
    let mut cpu = Simulation::new(make());
    let mut gpu = Simulation::with_gpu(make(), ctx);
    run(&mut cpu, 200);
    run(&mut gpu, 200);
    let (a, b) = (cpu.model.pores.as_ref().unwrap(), gpu.model.pores.as_ref().unwrap());
    let cracked = a.network.cracked.iter().filter(|&&c| c).count();
    assert!(cracked > 0, "no throat cracked");
    let g_max = a.network.conductance.iter().fold(0.0f64, |s, &g| s.max(g));
    let g_off =
        a.network.conductance.iter().zip(&b.network.conductance).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    // Mean conductance of the cracked throats, or of those still cemented (bonded at the build, intact).
    let mean = |f: &PoreFlow, want_cracked: bool| {
        let net = &f.network;
        let (s, n) = (0..net.throats.len())
            .filter(|&t| net.bonded_at_build[t] != 0 && net.cracked[t] == want_cracked)
            .fold((0.0, 0.0), |(s, n), t| (s + net.conductance[t], n + 1.0));
        s / n
    };
    let scale = a.pressure.iter().fold(0.0f64, |s, p| s.max(p.abs()));
    let worst = a.pressure.iter().zip(&b.pressure).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
    println!(
        "{cracked} cracked throats (mean g {:.3e}, gpu {:.3e}) against {:.3e} cemented; conductances apart by {g_off:.3e} of \
         a largest {g_max:.3e}; pressures apart by {worst:.3e} Pa of {scale:.3e} Pa",
        mean(a, true),
        mean(b, true),
        mean(a, false)
    );
    assert!(mean(a, true) > 2.0 * mean(a, false), "the cracks did not open their throats");
    assert!(g_off < 1e-4 * g_max, "GPU conductances depart {g_off:e} (largest {g_max:e})");
    assert!(scale > 0.0 && worst < 5e-3 * scale, "GPU pore pressures depart {worst:e} Pa (scale {scale:e} Pa)");
}
