//! The fluid's mass balance of the `pore_flow` stage on the GPU (f32) over long runs: a steady
//! flow through a column between two reservoirs must change the fluid it holds by exactly what
//! the reservoirs' pores booked (supplied − drained), and a sealed network must keep its mass.
//! In a steady flow each pore's net inflow per sub-step is far under the ulp of its excess mass
//! and the same every sub-step, so an update that rounds it away loses (or gains) the same mass
//! every sub-step while the reservoirs book the full flux: these tests fail without the per-pore
//! rounding carry of the excess masses. Both the flow update alone (`PoreFlowKernel`) and the
//! coupled stage in the backend's step (elements held, so the flow is all that runs). Skipped
//! without an adapter unless MATDEM_REQUIRE_GPU=1 (CI: lavapipe).
#![cfg(feature = "gpu")]

use crate::common::{gpu, pore_column};
use matdem_engine::backend::RunControl;
use matdem_engine::effects::pore_flow::gpu::PoreFlowKernel;
use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, PoreBoundary, PoreFlow, PoreRegion};
use matdem_engine::physics::Vec3;
use matdem_engine::state::particles::dof;
use matdem_engine::{Material, Model, Simulation};

const A: f64 = 1e-3;
/// The reservoirs: a pressurised formation (1 MPa) with a small head across the column (1 kPa),
/// so that each pore's excess mass is large against what flows through it in a sub-step.
const P_OUT: f64 = 1e6;
const P_IN: f64 = P_OUT + 1e3;

/// A simple-cubic column of spheres (r = 0.4 a, open throats), n × n × nz.
fn column(n: usize, nz: usize) -> Model {
    let mut m = Model::new();
    let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4 * A).unwrap()).unwrap();
    for k in 0..nz {
        for j in 0..n {
            for i in 0..n {
                m.add_particle(Vec3::new(i as f64, j as f64, k as f64) * A, 0.4 * A, mat).unwrap();
            }
        }
    }
    m
}

/// The fluid's books after a run against those before: (store change − net booked, net booked,
/// what the inlet supplied), kg.
struct Books {
    held: f64,
    booked: f64,
    inlet: f64,
}

impl Books {
    fn of(f: &PoreFlow) -> Self {
        Books { held: f.total_mass(), booked: f.boundary_mass, inlet: f.region_mass.first().copied().unwrap_or(0.0) }
    }

    /// |Δ held − Δ booked| over what the inlet supplied, and that supply.
    fn imbalance(&self, after: &Books) -> (f64, f64) {
        let supplied = after.inlet - self.inlet;
        let off = (after.held - self.held) - (after.booked - self.booked);
        (off.abs() / supplied.abs(), supplied)
    }
}

// 40,000 sub-steps of steady flow through a 4 × 4 × 12 column (the steady state set on the host
// first) between reservoirs at 1.001 MPa and 1 MPa, K_f = 1e7 Pa: the fluid the column holds
// changes by what the two reservoirs booked within 1e-5 of what the inlet supplied (measured on
// lavapipe: 2.8e-3 without the excess masses' carry, 4.1e-9 with it), and the inlet supplied
// the steady flux ρ0·Q·t within 1e-3 (measured 2e-5 with the carry, 7e-4 without).
#[test]
fn steady_flow_on_the_gpu_books_every_kilogram() {
    let Some(ctx) = gpu("pore_flow_steady_balance") else { return };
    let m = column(4, 12);
    let fluid = Fluid { bulk_modulus: 1e7, max_substeps: 1_000_000, ..Fluid::default() };
    let mut f = PoreFlow::new(&m, fluid).unwrap();
    let big = 1.0;
    f.set_boundaries(vec![
        PoreBoundary::boxed(Vec3::repeat(-big), Vec3::new(big, big, 0.5 * A), BoundaryKind::Pressure(P_IN)),
        PoreBoundary::boxed(Vec3::new(-big, -big, 10.5 * A), Vec3::repeat(big), BoundaryKind::Pressure(P_OUT)),
    ])
    .unwrap();
    f.solve_steady(1e-12).unwrap();
    f.substep(0.0);
    let q = f.boundary_flow[0];
    let (_, crit) = f.critical_dt();
    let h = 0.9 * crit;
    let n = 40_000;
    let before = Books::of(&f);
    let kernel = PoreFlowKernel::upload(&ctx, &f, h).unwrap();
    for _ in 0..(n / 5000) {
        kernel.substeps(&ctx, 5000);
    }
    kernel.download(&ctx, &mut f).unwrap();
    let (off, supplied) = before.imbalance(&Books::of(&f));
    let steady = f.fluid.density * q * h * f64::from(n);
    println!(
        "{} pores, {n} sub-steps of steady flow: inlet supplied {supplied:.4e} kg ({:+.2e} of the steady ρ0·Q·t); store \
         change − booked = {off:.2e} of the supply",
        f.mass.len(),
        supplied / steady - 1.0
    );
    assert!(q > 0.0, "no steady flow ({q:e} m³/s)");
    assert!(off < 1e-5, "the fluid's store departs its books by {off:e} of the supply");
    assert!(
        (supplied / steady - 1.0).abs() < 1e-3,
        "the inlet supplied {supplied:e} kg, the steady flux {steady:e} kg"
    );
}

// The same steady flow in the coupled stage (a 3 × 3 × 12 column of touching spheres, every
// element held, reservoirs in the pores of the bottom and top layers, 1500 steps of 21 flow
// sub-steps): the store's change is what the reservoirs booked within 1e-5 of the supply
// (measured on lavapipe: 8.9e-2 without the carry, 2.5e-8 with it), and the inlet supplied the
// host's steady flux within 1e-3 (measured 5.5e-5; 2.0e-3 while the device's equation of state
// used its own f32 pore volumes, ~1e-5 off the host's: ~10 Pa at 1 MPa against ~90 Pa of head
// across a layer).
#[test]
fn steady_flow_in_the_coupled_stage_on_the_gpu_books_every_kilogram() {
    let Some(ctx) = gpu("pore_flow_coupled_balance") else { return };
    let (nx, nz) = (3, 12);
    let mut m = pore_column(nx, nz, A, 1e6);
    let all: Vec<u32> = (0..m.len() as u32).collect();
    m.fix(&all, dof::ALL, true).unwrap();
    let layer = |k: usize| -> Vec<u32> { ((k * nx * nx) as u32..((k + 1) * nx * nx) as u32).collect() };
    m.settings.pores.fluid = Fluid { bulk_modulus: 1e7, viscosity: 1.0, max_substeps: 10_000, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    m.add_pore_boundary(PoreRegion::Elements(layer(0)), BoundaryKind::Pressure(P_IN)).unwrap();
    m.add_pore_boundary(PoreRegion::Elements(layer(nz - 1)), BoundaryKind::Pressure(P_OUT)).unwrap();
    // μ for ~20 flow sub-steps a mechanical step (the stable step grows with μ).
    let dt = m.clock.dt;
    let (_, crit) = m.pores.as_ref().unwrap().critical_dt();
    let mu = m.settings.pores.fluid.viscosity * dt / (20.0 * 0.9 * crit);
    m.set_pore_fluid(Fluid { viscosity: mu, ..m.settings.pores.fluid.clone() }).unwrap();
    let f = m.pores.as_mut().unwrap();
    f.solve_steady(1e-12).unwrap();
    f.substep(0.0);
    let q = f.boundary_flow[0];
    let before = Books::of(f);
    let mut sim = Simulation::with_gpu(m, ctx);
    let steps = 1500;
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
    let f = sim.model.pores.as_ref().unwrap();
    let (off, supplied) = before.imbalance(&Books::of(f));
    let steady = f.fluid.density * q * dt * steps as f64;
    println!(
        "{} pores, {steps} coupled steps ({} flow sub-steps a step): inlet supplied {supplied:.4e} kg ({:+.2e} of the \
         steady ρ0·Q·t); store change − booked = {off:.2e} of the supply; {} rebuilds",
        f.mass.len(),
        f.substeps,
        supplied / steady - 1.0,
        f.rebuilds
    );
    assert_eq!(f.rebuilds, 0, "held elements rebuilt the network");
    assert!(off < 1e-5, "the fluid's store departs its books by {off:e} of the supply");
    assert!(
        (supplied / steady - 1.0).abs() < 1e-3,
        "the inlet supplied {supplied:e} kg, the steady flux {steady:e} kg"
    );
}

// Sealed, from an uneven start at a high pressure, 40,000 sub-steps: the fluid's mass on the
// device is conserved to round-off, 5e-12 of itself (measured on lavapipe: 5.4e-13 with the
// carry, 2.7e-8 without it).
#[test]
fn sealed_flow_on_the_gpu_keeps_its_mass_over_many_sub_steps() {
    let Some(ctx) = gpu("pore_flow_sealed_balance") else { return };
    let m = column(4, 6);
    let mut f = PoreFlow::new(&m, Fluid { bulk_modulus: 1e7, max_substeps: 1_000_000, ..Fluid::default() }).unwrap();
    for (p, mass) in f.mass.iter_mut().enumerate() {
        *mass *= 1.1 + 1e-3 * (p % 7) as f64;
    }
    f.update_pressure();
    let m0 = f.total_mass();
    let (_, crit) = f.critical_dt();
    let kernel = PoreFlowKernel::upload(&ctx, &f, 0.9 * crit).unwrap();
    for _ in 0..8 {
        kernel.substeps(&ctx, 5000);
    }
    kernel.download(&ctx, &mut f).unwrap();
    let drift = (f.total_mass() - m0).abs() / m0;
    println!("sealed: mass drift {drift:.2e} of itself after 40,000 sub-steps");
    assert!(f.boundary_mass == 0.0, "sealed boundaries booked {:e} kg", f.boundary_mass);
    assert!(drift < 5e-12, "mass changed by {drift:e} of itself");
}
