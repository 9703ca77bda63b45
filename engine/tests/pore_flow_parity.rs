//! The `pore_flow` stage's flow update on the GPU (shaders/pore_flow.wgsl, f32) against the
//! CPU (`PoreFlow::substep`, f64): an uneven start in a simple-cubic column with a reservoir at
//! each end and an injection well, and mass conservation with every boundary sealed. Skipped
//! without an adapter unless MATDEM_REQUIRE_GPU=1 (CI: lavapipe).
#![cfg(feature = "gpu")]

use crate::common::gpu;
use matdem_engine::backend::gpu::pore_flow::PoreFlowKernel;
use matdem_engine::physics::Vec3;
use matdem_engine::pores::{BoundaryKind, Fluid, PoreBoundary, PoreFlow, PoreRegion};
use matdem_engine::{Material, Model};

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
    let kernel = PoreFlowKernel::upload(&ctx, &gpu_f, h);
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
    let kernel = PoreFlowKernel::upload(&ctx, &f, 0.9 * crit);
    kernel.substeps(&ctx, 2000);
    kernel.download(&ctx, &mut f).unwrap();
    let drift = (f.total_mass() - m0).abs() / m0;
    let (lo, hi) = f.pressure.iter().fold((f64::MAX, f64::MIN), |(a, b), &p| (a.min(p), b.max(p)));
    println!("mass drift {drift:.2e}; pressures {lo:.4e} .. {hi:.4e} Pa");
    assert!(drift < 1e-9, "mass changed by {drift:e} of itself");
    assert!(hi - lo < 1e-2 * hi.abs(), "pressure still ranges {lo}..{hi}");
}
