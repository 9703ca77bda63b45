//! Material training: the numerical tests against the lattice formulas, invalid targets,
//! element-size scaling, and the training loop converging on a small sample.
//! Heavy: run in release mode.

use matdem_engine::backend::RunControl;
use matdem_engine::builder::fcc_111_block;
use matdem_engine::training::{
    run_test, train, validate_targets, Dimension, LabTest, Loading, PackedSample, SampleSpec, TrainOptions,
};
use matdem_engine::{MacroProperties, Material};

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

fn soil() -> MacroProperties {
    MacroProperties { young: 5e7, poisson: 0.15, tensile: 2e4, compressive: 2e5, internal_friction: 0.6 }
}

/// A bonded FCC block, close-packed layers normal to z ([111]), that never breaks.
fn fcc_sample(nu: f64) -> (PackedSample, Material) {
    let d = 2e-3;
    let pos = fcc_111_block(6, 6, 9, d);
    // A hair over d/2 so every lattice neighbour counts as touching despite round-off.
    let radius = vec![0.5 * d * (1.0 + 1e-9); pos.len()];
    let p = MacroProperties { young: 1e9, poisson: nu, tensile: 1e9, compressive: 1e10, internal_friction: 1.0 };
    let m = Material::from_macro("lattice", 2650.0, &p, d).unwrap();
    (PackedSample { pos, radius, steps: 0, thickness: None }, m)
}

fn bounds(m: &matdem_engine::Model) -> ([f64; 3], [f64; 3]) {
    let p = &m.particles;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (x, r) in p.pos.iter().zip(&p.radius) {
        for k in 0..3 {
            lo[k] = lo[k].min(x[k] - r);
            hi[k] = hi[k].max(x[k] + r);
        }
    }
    (lo, hi)
}

#[test]
fn uniaxial_compression_of_fcc_111_block_measures_lattice_e_and_nu() {
    // physics.md §3: an FCC block loaded along [111] at small strain returns the lattice
    // E and ν. Here through the test's own path: platens, strain ramp, displacement fit.
    let ctl = RunControl::default();
    for nu in [0.05, 0.15] {
        let (sample, m) = fcc_sample(nu);
        let bonded = sample.bonded(&m, &ctl).unwrap();
        let expect = m.lattice_macro(2e-3);
        let mut loading = Loading::reaching_peak_in(1500.0, 1e-4);
        loading.max_strain_factor = 1.0;
        let r = run_test(&bonded, LabTest::UniaxialCompression, &loading, &ctl).unwrap();
        // The test divides the platen force by the bounding box's section; the lattice
        // carries it on n·(√3/2)·d² per close-packed layer (36 spheres a layer here).
        let (lo, hi) = bounds(&bonded);
        let lattice_area = 36.0 * 3f64.sqrt() / 2.0 * 4e-6;
        let young = r.young * (hi[0] - lo[0]) * (hi[1] - lo[1]) / lattice_area;
        // Grains on the free sides have fewer bonds, so a 6 × 6 section carries less than
        // the infinite lattice (lattice.rs finds the interior within 1 %): softer, not stiffer.
        assert!(young < expect.young && young > 0.75 * expect.young, "ν {nu}: E {young} vs lattice {}", expect.young);
        assert!(
            (r.poisson - expect.poisson).abs() < 0.02,
            "ν {nu}: measured {} vs lattice {}",
            r.poisson,
            expect.poisson
        );
        assert!(!r.peaked, "nothing breaks, so the stress must still be rising");
    }
}

#[test]
fn invalid_targets_are_refused_with_what_to_do() {
    type Spoil = fn(&mut MacroProperties);
    let cases: [(Spoil, &str); 6] = [
        (|p| p.poisson = 0.25, "ν ≤ 0.2"),
        (|p| p.internal_friction = 0.3, "μi ≥ 0.354"),
        (|p| p.tensile = -1.0, "> 0"),
        (|p| p.compressive = f64::NAN, "finite"),
        (|p| p.young = 0.0, "> 0"),
        (|p| p.tensile = 3e5, "smaller than the compressive"),
    ];
    for (spoil, hint) in cases {
        let mut p = soil();
        spoil(&mut p);
        let e = validate_targets(&p, Dimension::Three).unwrap_err().to_string();
        assert!(e.contains(hint), "{e}");
        // train refuses before building anything.
        let e = train("bad", &p, &TrainOptions::default(), &RunControl::default(), &mut |_| {}).unwrap_err();
        assert!(e.to_string().contains(hint), "{e}");
    }
    assert!(validate_targets(&soil(), Dimension::Three).is_ok());
}

#[test]
fn rescaled_material_on_a_scaled_sample_gives_the_same_curve() {
    // Paper 001 §2: elements twice as large with Kn ∝ d, Kn/Ks kept, Xb ∝ d and Fs0 ∝ d²
    // carry the same stresses at the same strains. On the same packing scaled by 2 the
    // whole uniaxial test is the same in dimensionless form, so E and Cu agree to round-off.
    let ctl = RunControl::default();
    let spec = SampleSpec { elements: 150, ..SampleSpec::default() };
    let m = Material::from_macro("soil", 2000.0, &soil(), 2e-3).unwrap();
    let small = PackedSample::pack(&spec, &m, &ctl).unwrap();
    let large = small.scaled(2.0);
    let m2 = m.rescaled(small.diameter(), large.diameter()).unwrap();
    assert!(rel(m2.kn / large.diameter(), m.kn / small.diameter()) < 1e-12);
    assert!(rel(m2.kn / m2.ks, m.kn / m.ks) < 1e-12);
    let loading = Loading::reaching_peak_in(3000.0, 4e-3);
    let a = run_test(&small.bonded(&m, &ctl).unwrap(), LabTest::UniaxialCompression, &loading, &ctl).unwrap();
    let b = run_test(&large.bonded(&m2, &ctl).unwrap(), LabTest::UniaxialCompression, &loading, &ctl).unwrap();
    assert!(a.peak_stress > 0.0 && a.young > 0.0);
    assert!(rel(b.young, a.young) < 1e-6, "E {} vs {}", b.young, a.young);
    assert!(rel(b.peak_stress, a.peak_stress) < 1e-6, "Cu {} vs {}", b.peak_stress, a.peak_stress);
    // The lattice view agrees: the rescaled material has the same macro properties.
    let (pa, pb) = (m.lattice_macro(small.diameter()), m2.lattice_macro(large.diameter()));
    assert!(rel(pb.young, pa.young) < 1e-9 && rel(pb.compressive, pa.compressive) < 1e-9);
}

#[test]
fn training_converges_for_a_soil_like_material_on_a_small_sample() {
    // Issue 5's soil (E 50 MPa, ν 0.15, Tu 20 kPa, Cu 200 kPa, μi 0.6) on 200 elements,
    // loaded at 4000 steps to the expected peak: within E, Tu, Cu ± 5 %, ν ± 0.02 and
    // μi ± 0.05 in at most 6 rounds (measured: round 4, about 8 s on 2 cores).
    let t = soil();
    let opts = TrainOptions {
        sample: SampleSpec { elements: 200, ..SampleSpec::default() },
        density: 2000.0,
        steps_to_peak: 4000.0,
        ..TrainOptions::default()
    };
    let mut seen = 0;
    let r = train("soil", &t, &opts, &RunControl::default(), &mut |_| seen += 1).unwrap();
    assert_eq!(seen, r.rounds.len());
    assert!(
        r.converged && r.rounds.len() <= 6,
        "rounds: {:#?}",
        r.rounds.iter().map(|x| x.measured).collect::<Vec<_>>()
    );
    let m = &r.best_round().measured;
    assert!(rel(m.young, t.young) <= 0.05, "E {}", m.young);
    assert!((m.poisson - t.poisson).abs() <= 0.02, "ν {}", m.poisson);
    assert!(rel(m.tensile, t.tensile) <= 0.05, "Tu {}", m.tensile);
    assert!(rel(m.compressive, t.compressive) <= 0.05, "Cu {}", m.compressive);
    assert!((m.internal_friction - t.internal_friction).abs() <= 0.05, "μi {}", m.internal_friction);
    // The lattice formulas alone are far off on a random packing: training did the work.
    let first = &r.rounds[0].measured;
    assert!(rel(first.young, t.young) > 0.2, "round 1 E {}", first.young);
    // The saved file rescales to another element size keeping Kn/d and Kn/Ks.
    let file = r.trained_material();
    let big = file.for_diameter(2.0 * file.diameter).unwrap();
    assert!(rel(big.kn / big.ks, file.material.kn / file.material.ks) < 1e-12);
    assert!(rel(big.kn, 2.0 * file.material.kn) < 1e-12);
}

#[test]
fn training_converges_in_2d_for_a_soil_like_material_on_a_small_layer() {
    // The soil (ν 0.25, beyond the 3D formulas) on a 2D sample (300 elements in one layer in
    // the x–z plane, made 2D), started from the hexagonal layer's formulas: the same
    // tolerances as in 3D in at most 6 rounds (measured: round 3, about 4 s on 2 cores; round
    // 1 read E 14 MPa and ν 0.32 — a random layer is far from the hexagonal one).
    let t = MacroProperties { poisson: 0.25, ..soil() };
    let opts = TrainOptions {
        sample: SampleSpec { elements: 300, dimension: Dimension::Two, ..SampleSpec::default() },
        density: 2000.0,
        steps_to_peak: 4000.0,
        ..TrainOptions::default()
    };
    let r = train("soil_2d", &t, &opts, &RunControl::default(), &mut |r| {
        eprintln!("2D round {}: measured {:?}, {:.1} s", r.round, r.measured, r.wall_seconds)
    })
    .unwrap();
    let m = &r.best_round().measured;
    assert!(
        r.converged && r.rounds.len() <= 6,
        "rounds: {:#?}",
        r.rounds.iter().map(|x| x.measured).collect::<Vec<_>>()
    );
    assert!(rel(m.young, t.young) <= 0.05, "E {}", m.young);
    assert!((m.poisson - t.poisson).abs() <= 0.02, "ν {}", m.poisson);
    assert!(rel(m.tensile, t.tensile) <= 0.05, "Tu {}", m.tensile);
    assert!(rel(m.compressive, t.compressive) <= 0.05, "Cu {}", m.compressive);
    assert!((m.internal_friction - t.internal_friction).abs() <= 0.05, "μi {}", m.internal_friction);
    assert_eq!(r.trained_material().dimension, Dimension::Two);
    // The 3D formulas would refuse ν 0.25; the 2D ones take it.
    assert!(validate_targets(&t, Dimension::Three).is_err() && validate_targets(&t, Dimension::Two).is_ok());
}
