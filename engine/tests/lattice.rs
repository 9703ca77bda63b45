//! The macro ↔ micro conversion against the lattice it is derived for: a perfect FCC block,
//! every touching pair bonded, compressed along [111] (normal to its close-packed layers)
//! at a small strain must return the E and ν its springs were computed from.
//!
//! Reference: /work/shared/reference/physics.md §3 (paper 003, appendix A): Kn, Ks from E, ν
//! for d = 1 mm; "a perfect FCC block compressed along [111] at strain < 1e-4 should return E
//! and ν within 1–2% (boundary effects)". Tolerance: 2% on E; on ν, 2% of ν or 0.002 at ν = 0
//! (|Δν| ≤ 0.02·max(ν, 0.1)). The exact round trip of the formulas is a unit test in
//! materials.rs; this test runs the engine.
//!
//! How the formulas define stress and strain, and how the test measures them:
//! - They hold for an infinite lattice under uniaxial stress (σxx = σyy = 0), where every
//!   element is a centre of symmetry, so the deformation is affine.
//! - Stress is force per cross-section, and the cross-section per element of a close-packed
//!   layer is √3/2·d² (layer spacing √(2/3)·d, volume per element d³/√2). σzz is the mean
//!   force the elements of the top layer receive from the layer below, over √3/2·d², taken over
//!   elements at least 3d from the free sides: at the sides elements lack bonds, so the
//!   whole-layer force over N·√3/2·d² reads about 10% low (printed as "whole layer").
//! - εzz is imposed: the bottom layer is held in z, the top layer moved in z at constant
//!   speed (so the incremental shear springs see the motion), then held; both are free in x
//!   and y (frictionless plates). Lateral strain is the slope of the lateral displacement
//!   against position over the mid-height layer, at least 2d from the sides.
//! - A finite stack of L layers has L layers of in-plane bonds but L − 1 gaps of inter-layer
//!   bonds, one in-plane layer too many: the end layers act as a skin that pulls the block in
//!   (ν read 9% low with 8 layers of 12 × 12). In a periodic column the top layer is the
//!   image of the bottom one, so its in-plane bonds are the bottom layer's, counted once: the
//!   test removes the top layer's in-plane bonds. Then the affine uniaxial state is an exact
//!   equilibrium of every element away from the free sides (each top element sits on three
//!   symmetric bonds): the periodic-like constraint the brief allows.
//!
//! Run with `cargo test -p matdem-engine --release --test lattice -- --nocapture` to see the
//! measured values.

use matdem_engine::backend::RunControl;
use matdem_engine::builder::fcc_111_block;
use matdem_engine::state::particles::dof;
use matdem_engine::{MacroProperties, Material, Model, Simulation};

/// Element diameter (m).
const D: f64 = 1e-3;
/// Elements per close-packed row and rows per layer.
const N: usize = 18;
/// Close-packed layers.
const LAYERS: usize = 6;
/// Imposed axial strain (compression).
const STRAIN: f64 = 5e-5;

/// What one compression test measured.
struct Measured {
    young: f64,
    poisson: f64,
    /// E from the whole top layer's force over N²·√3/2·d² (side effects included).
    young_whole_layer: f64,
    /// Unbalanced force ratio at the end (equilibrium check).
    unbalanced: f64,
    secs: f64,
}

/// Compresses an N × N × LAYERS FCC block along [111] by STRAIN and measures E and ν.
fn compress_along_111(poisson: f64) -> Measured {
    let props = MacroProperties {
        young: 1e9,
        poisson,
        // Far above the stresses of the test: no bond breaks.
        tensile: 1e9,
        compressive: 1e10,
        internal_friction: 0.6,
    };
    let mut m = Model::new();
    m.add_material(Material::from_macro("lattice", 2600.0, &props, D).unwrap()).unwrap();
    for p in fcc_111_block(N, N, LAYERS, D) {
        m.add_particle(p, D / 2.0, 0).unwrap();
    }
    m.connect(None, 0.01 * D).unwrap();
    let per_layer = N * N;
    let bottom: Vec<u32> = (0..per_layer as u32).collect();
    let top: Vec<u32> = ((LAYERS - 1) * per_layer..LAYERS * per_layer).map(|i| i as u32).collect();
    // The top layer is the bottom layer's periodic image: its in-plane bonds are not its own.
    for (k, &i) in top.iter().enumerate() {
        for &j in &top[k + 1..] {
            m.contacts.set_bond(i as usize, j as usize, false);
        }
    }
    m.fix(&bottom, dof::Z, true).unwrap();
    m.fix(&top, dof::Z, true).unwrap();
    // Damping only speeds up the approach to static equilibrium.
    m.settings.damping = 0.2;
    let dt = m.set_standard_dt().unwrap();
    let height = (LAYERS - 1) as f64 * D * (2.0f64 / 3.0).sqrt();
    let load_steps = 1500;
    let speed = STRAIN * height / (load_steps as f64 * dt);
    for &i in &top {
        m.particles.vel[i as usize].z = -speed;
    }
    let mut sim = Simulation::new(m);
    let ctl = RunControl::default();
    let t0 = std::time::Instant::now();
    sim.run(load_steps, &ctl, &mut |_| {}).unwrap();
    for &i in &top {
        sim.model.particles.vel[i as usize].z = 0.0;
    }
    sim.run(2500, &ctl, &mut |_| {}).unwrap();
    let secs = t0.elapsed().as_secs_f64();
    let unbalanced = sim.contact_stats().unbalanced_ratio;

    let p = &sim.model.particles;
    let t = top[0] as usize;
    let strain = (p.origin[t].z - p.pos[t].z) / height;
    // Elements at least `margin` from the free sides (the block spans N·d in x, N·√3/2·d in y).
    let (x0, y0) = (p.origin[0].x, p.origin[0].y);
    let inside = |i: usize, margin: f64| {
        let o = p.origin[i];
        o.x > x0 + margin
            && o.x < x0 + N as f64 * D - margin
            && o.y > y0 + margin
            && o.y < y0 + N as f64 * D * 3f64.sqrt() / 2.0 - margin
    };
    let area = 3f64.sqrt() / 2.0 * D * D;
    let inner: Vec<usize> = top.iter().map(|&i| i as usize).filter(|&i| inside(i, 3.0 * D)).collect();
    let force: f64 = inner.iter().map(|&i| p.force[i].z).sum();
    let young = force / (inner.len() as f64 * area) / strain;
    let whole: f64 = top.iter().map(|&i| p.force[i as usize].z).sum();
    let young_whole_layer = whole / (per_layer as f64 * area) / strain;
    // Lateral strain: least-squares slope of u_x against x and of u_y against y.
    let mid = LAYERS / 2;
    let ids: Vec<usize> = (mid * per_layer..(mid + 1) * per_layer).filter(|&i| inside(i, 2.0 * D)).collect();
    let slope = |c: usize| {
        let n = ids.len() as f64;
        let u = |i: usize| p.pos[i][c] - p.origin[i][c];
        let mx = ids.iter().map(|&i| p.origin[i][c]).sum::<f64>() / n;
        let mu = ids.iter().map(|&i| u(i)).sum::<f64>() / n;
        let sxy: f64 = ids.iter().map(|&i| (p.origin[i][c] - mx) * (u(i) - mu)).sum();
        let sxx: f64 = ids.iter().map(|&i| (p.origin[i][c] - mx).powi(2)).sum();
        sxy / sxx
    };
    let lateral = 0.5 * (slope(0) + slope(1));
    Measured { young, poisson: lateral / strain, young_whole_layer, unbalanced, secs }
}

#[test]
fn fcc_lattice_along_111_returns_lattice_e_and_nu() {
    for nu in [0.0, 0.1, 0.2] {
        let r = compress_along_111(nu);
        let e_err = r.young / 1e9 - 1.0;
        eprintln!(
            "FCC [111], ν = {nu}: E {:.5e} Pa ({e_err:+.2e}), ν {:.5} ({:+.5}); whole-layer E \
             {:.4e} Pa; unbalanced ratio {:.1e}; {} elements, {:.1} s",
            r.young,
            r.poisson,
            r.poisson - nu,
            r.young_whole_layer,
            r.unbalanced,
            N * N * LAYERS,
            r.secs
        );
        assert!(r.unbalanced < 1e-3, "ν = {nu}: not in static equilibrium ({:e})", r.unbalanced);
        assert!(e_err.abs() < 0.02, "ν = {nu}: E off by {e_err:e}");
        assert!((r.poisson - nu).abs() <= 0.02 * nu.max(0.1), "ν = {nu}: measured ν {}", r.poisson);
    }
}
