//! The triaxial example (examples/triaxial) in quick mode through the CLI: a packed sand
//! cylinder, its ring replaced by the membrane (the `confining_pressure` stage), consolidated and
//! sheared quasi-statically at three cell pressures. The membrane holds σ3 on the side within 2 %
//! through every test, the peaks rise with σ3, the envelope is a friction envelope, and the
//! charts and tables are written.

use crate::common::*;

#[test]
fn triaxial_quick_mode_holds_the_cell_pressure_and_fits_a_friction_envelope() {
    let dir = temp_dir("triaxial_quick");
    let out = dir.join("out");
    let (log, wall) = run_example_quick("triaxial", &out);
    eprintln!("triaxial quick mode: {wall:.1} s wall\n{log}");
    for name in ["q_strain", "volumetric_strain", "envelope"] {
        for ext in ["svg", "png"] {
            let f = out.join(format!("{name}.{ext}"));
            let len = std::fs::metadata(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display())).len();
            assert!(len > 1000, "{} is only {len} bytes", f.display());
        }
    }
    let runs = out.join("runs.csv");
    let s3 = csv_column(&runs, "sigma3");
    assert_eq!(s3, [50e3, 100e3, 200e3]);
    for (k, kpa) in [50, 100, 200].into_iter().enumerate() {
        let curve = out.join(format!("triaxial_{kpa}kPa.csv"));
        // The side stress the membrane applies, every row: σ3 within 2 % (measured: within 0.8 %).
        for side in csv_column(&curve, "side_stress") {
            assert!((side - s3[k]).abs() < 0.02 * s3[k], "{kpa} kPa: side stress {side} Pa");
        }
        // Every cell of the membrane touched or covered by a neighbour's grain.
        assert!(csv_column(&curve, "covered").iter().all(|&c| c > 0.98), "{kpa} kPa: cells left bare");
        // Quasi-static: the default inertial number 1e-3 keeps the unbalanced force ratio low
        // (a shear 10 times faster ran at 0.3–0.37 with a dynamic spike of q at 0.15 %).
        let unbalanced = csv_column(&curve, "unbalanced_ratio");
        assert!(unbalanced.iter().skip(1).all(|&u| u < 0.15), "{kpa} kPa: unbalanced {unbalanced:?}");
        // Consolidated isotropically: q starts at σ3's few percent at most.
        let q = csv_column(&curve, "q");
        assert!(q[0].abs() < 0.05 * s3[k], "{kpa} kPa: q at the start {}", q[0]);
    }
    let peaks = csv_column(&runs, "peak_q");
    assert!(peaks.windows(2).all(|w| w[1] > w[0]), "peaks rise with σ3: {peaks:?}");
    let m = metrics(&out);
    let phi = m["phi_deg"];
    // Spheres with rotation and μ = 0.5, loose from deposition: measured 20.1°, c 6.5 kPa.
    assert!((10.0..45.0).contains(&phi), "φ = {phi}°: {m:?}");
    assert!(log.contains("confining pressure(σ3 = "), "the plan lists the stage:\n{log}");
}

// The example's 2D mode (`--set dimension=2`, MatDEM's biaxial tests): the same three cell
// pressures on a plate of discs, σ3 held on its sides in every row, a friction envelope.
// Measured: 334 discs, peaks 49/98/248 kPa, φ 23.7°, about 25 s.
#[test]
fn the_triaxial_example_runs_biaxial_tests_in_2d() {
    let dir = temp_dir("biaxial_example");
    let out = dir.join("out");
    let (log, _) = run_example_quick_with("triaxial", &out, &["dimension=2"]);
    assert!(log.contains("discs in a box"), "{log}");
    for kpa in [50.0, 100.0, 200.0] {
        let curve = out.join(format!("triaxial_{kpa}kPa.csv"));
        for side in csv_column(&curve, "side_stress") {
            assert!((side - kpa * 1e3).abs() < 0.02 * kpa * 1e3, "{kpa} kPa: side stress {side} Pa");
        }
    }
    let phi = metrics(&out)["phi_deg"];
    assert!((10.0..45.0).contains(&phi), "φ = {phi}°");
}

/// A quick sand cylinder (3 mm × 6 mm, ~365 grains of 0.4 mm ± 20 %) packed under gravity in
/// its ring, with a top platen: `d` for the scripted tests below.
/// A cylinder's builder settings, for the refusals.
const CYLINDER: &str = "b.sample_r = 0.003; b.sample_h = 0.006;";

/// Builds a box of 0.4 mm grains with `sample` (its builder settings) and runs `call` on it,
/// which must fail before any work: its stderr.
fn refused(dir: &std::path::Path, name: &str, sample: &str, call: &str) -> String {
    let script = format!(
        "let b = new_box(\"t\"); {sample} b.ball_r = 0.4e-3; b.set_type(\"top_platen\");\nlet d = b.build_initial_model();\n{call}"
    );
    let o = run_script(dir, &format!("{name}.rhai"), &script, &["--backend", "cpu"]);
    assert!(!o.status.success(), "{name}: {}", stdout(&o));
    stderr(&o)
}

const PACKED: &str = r#"
let b = new_box("t");
b.sample_r = 0.003; b.sample_h = 0.006;
b.ball_r = 0.4e-3; b.distri_rate = 0.2; b.seed = 7;
b.set_type("top_platen");
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("sand", #{ kn: 2e5, ks: 8e4, mu_p: 0.5, r: 0.4e-3, restitution: 0.5, density: 2650.0 }));
d.set_standard_dt();
sediment(d, #{ accel: 30.0, tolerance: 0.05 });
"#;

// Stress control: `triaxial(d, #{ confining, stages })` holds each σ1 with the platen's servo on
// the sample's cross-section; the rows reach each stage within 3 % (the servo's own tolerance is
// 2 % of its nominal-area stress), the side stays at σ3 within 2 % and the sample shortens.
#[test]
fn a_stress_controlled_triaxial_test_reaches_each_stage() {
    let dir = temp_dir("triaxial_stress");
    let script = format!(
        "{PACKED}{}",
        r#"
let r = triaxial(d, #{ confining: 50e3, stages: [75e3, 100e3, 125e3], tolerance: 0.05 });
r.curve.save("stress.csv");
"#
    );
    let o = run_script(&dir, "stress.rhai", &script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = dir.join("out/stress.csv");
    let s1 = csv_column(&csv, "sigma1");
    for (row, want) in s1.iter().skip(1).zip([75e3, 100e3, 125e3]) {
        assert!((row - want).abs() < 0.03 * want, "σ1 {row} Pa for {want}: {s1:?}");
    }
    assert!(csv_column(&csv, "side_stress").iter().all(|s| (s - 50e3).abs() < 1e3));
    let ea = csv_column(&csv, "axial_strain");
    assert!(ea.windows(2).all(|w| w[1] > w[0]), "the sample shortens: {ea:?}");
}

/// The pore-fluid tests' fluid for the `PACKED` cylinder (1000 × water's viscosity: the flow's
/// stable sub-step then fits the step ~14 times); `triaxial` saturates the sample with it.
const FLUID: &str = "d.fluid = #{ bulk_modulus: 4e7, viscosity: 1.0 };\n";

// The effective stress principle, drained: a saturated sample under an isotropic increment of
// the cell pressure (50 → 60 kPa) first carries part of it in its pore fluid, which drains
// through the platens, and ends where the same sample dry does. Measured: u 122 Pa after 2,000
// steps, 1.0 Pa at the end (pores the drained network does not reach); ε_v 2.678e-4 wet
// against 2.698e-4 dry (0.7 %).
#[test]
fn a_drained_saturated_sample_settles_where_the_dry_one_does() {
    let dir = temp_dir("triaxial_drained_increment");
    let script = format!(
        "{PACKED}{FLUID}{}",
        r#"
triaxial(d, #{ confining: 50e3, stages: [], tolerance: 0.05, pore_fluid: "drained" });
d.save("consolidated");
let rows = new_table();
for wet in [false, true] {
    let t = load_model("consolidated");
    if !wet { t.disable("pore_flow"); }
    let v0 = t.membrane().volume;
    let h = t.boundary("top_platen").position[2] - t.boundary("bottom").position[2];
    t.confine(#{ pressure: 60e3, bottom: "bottom", top: "top_platen" });
    t.set_platen_stress("top_platen", 60e3 * v0 / h / t.boundary("top_platen").area);
    for k in 0..12 {
        t.run(2000);
        let u = if wet { t.pore_network.mean_pressure } else { 0.0 };
        rows.add_row(#{ wet: if wet { 1.0 } else { 0.0 }, volumetric_strain: (v0 - t.membrane().volume) / v0, u: u });
    }
}
rows.save("increment.csv");
"#
    );
    let o = run_script(&dir, "increment.rhai", &script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = dir.join("out/increment.csv");
    let (wet, ev, u) = (csv_column(&csv, "wet"), csv_column(&csv, "volumetric_strain"), csv_column(&csv, "u"));
    let dry_end = ev[11];
    let (wet_u, wet_end) = (&u[12..], ev[23]);
    assert!(wet[..12].iter().all(|&w| w == 0.0) && wet[12..].iter().all(|&w| w == 1.0));
    eprintln!("drained increment: u {wet_u:?}; ε_v dry {dry_end:e}, wet {wet_end:e}");
    // The fluid took part of the 10 kPa at first, and drained to under 0.1 % of it.
    assert!(wet_u[0] > 20.0, "the increment raised no pore pressure: {wet_u:?}");
    assert!(wet_u[11].abs() < 10.0, "the pore pressure did not drain: {wet_u:?}");
    // Drained, the skeleton carries the whole increment: the dry sample's strain within 2 %.
    assert!(dry_end > 1e-4, "the increment compressed the dry sample by only {dry_end:e}");
    assert!((wet_end - dry_end).abs() < 0.02 * dry_end, "ε_v wet {wet_end:e}, dry {dry_end:e}");
}

// Sheared faster than the pore fluid drains, the rows carry the excess pore pressure and the
// effective mean stress p' = (σ1 + 2σ3)/3 − u, and the procedure says the test was not drained.
// An undrained test of a membrane sample is refused before any work, with the reason and what
// to build instead.
#[test]
fn a_saturated_triaxial_test_reports_its_pore_pressure() {
    let dir = temp_dir("triaxial_drained_shear");
    let script = format!(
        "{PACKED}{FLUID}{}",
        r#"
let r = triaxial(d, #{ confining: 50e3, strain: 0.01, points: 4, tolerance: 0.05, pore_fluid: "drained" });
r.curve.save("wet.csv");
report("phi_eff", r.phi_eff);
report("u_max", r.pore_pressure_max);
"#
    );
    let o = run_script(&dir, "wet.rhai", &script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let log = stdout(&o) + stderr(&o).as_str();
    let csv = dir.join("out/wet.csv");
    let (s1, u, p) = (csv_column(&csv, "sigma1"), csv_column(&csv, "pore_pressure"), csv_column(&csv, "p_eff"));
    eprintln!("drained shear: u {u:?}");
    for k in 0..u.len() {
        assert!(
            (p[k] - ((s1[k] + 1e5) / 3.0 - u[k])).abs() < 1e-6 * p[k],
            "row {k}: p' {} σ1 {} u {}",
            p[k],
            s1[k],
            u[k]
        );
    }
    // Measured 3.3 kPa at 0.25 % strain with this fluid (407 Pa with a tenth of its viscosity).
    let u_max = metrics(&dir.join("out"))["u_max"];
    assert!(u_max > 0.05 * 50e3 && u_max < 50e3, "u_max {u_max} Pa");
    assert!(log.contains("not drained at this rate"), "{log}");

    let e = refused(&dir, "undrained", CYLINDER, r#"triaxial(d, #{ confining: 50e3, pore_fluid: "undrained" });"#);
    assert!(e.contains("which the membrane cannot") && e.contains("build the sample as a box"), "{e}");
}

// An undrained test at constant volume (`pore_fluid: "undrained"` on a box sample: the side
// walls move out as the platen comes down, u = σ3 − σ3'). A loose packing (deposited with
// friction) liquefies: its water takes nearly all the cell pressure. A dense one (deposited
// frictionless, then given the same friction) dilates: its pore pressure falls below zero and
// its effective stress climbs far above σ3. Both keep their volume to round-off, and every row
// keeps p' = (σ1 + 2σ3)/3 − u. Measured (646 grains, 5 × 5 × 12 mm, σ3 50 kPa, to 10 %): loose
// u up to 49.6 kPa, p' ending at 7.4 kPa; dense u −794 kPa and p' 1.8 MPa at the end, φ' 39°.
#[test]
fn an_undrained_box_test_holds_its_volume_and_its_pore_pressure_follows_the_packing() {
    let dir = temp_dir("triaxial_undrained");
    let script = r#"
for dense in [false, true] {
    let b = new_box("t");
    b.sample_w = 0.005; b.sample_l = 0.005; b.sample_h = 0.012;
    b.ball_r = 0.4e-3; b.distri_rate = 0.2; b.seed = 7;
    b.set_type("top_platen");
    let d = b.build_initial_model();
    let sand = #{ kn: 2e5, ks: 8e4, mu_p: 0.5, r: 0.4e-3, restitution: 0.5, density: 2650.0 };
    let deposit = sand; deposit.mu_p = if dense { 0.0 } else { 0.5 };
    d.set_group_mat("sample", material_micro("deposit", deposit));
    d.set_standard_dt();
    d.enable("rotation");
    sediment(d, #{ accel: 30.0, tolerance: 0.05 });
    d.set_group_mat("sample", material_micro("sand", sand));
    let r = triaxial(d, #{ confining: 50e3, strain: 0.1, points: 20, pore_fluid: "undrained" });
    let name = if dense { "dense" } else { "loose" };
    r.curve.save(`${name}.csv`);
    report(`${name}_phi_eff`, r.phi_eff);
}
"#;
    let o = run_script(&dir, "undrained.rhai", script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s3 = 50e3;
    for name in ["loose", "dense"] {
        let csv = dir.join(format!("out/{name}.csv"));
        let (s1, u, p, ev) = (
            csv_column(&csv, "sigma1"),
            csv_column(&csv, "pore_pressure"),
            csv_column(&csv, "p_eff"),
            csv_column(&csv, "volumetric_strain"),
        );
        eprintln!(
            "{name}: u {u:?}
p' {p:?}"
        );
        for k in 0..u.len() {
            assert!(ev[k].abs() < 1e-9, "{name} row {k}: the volume changed by {}", ev[k]);
            assert!(
                (p[k] - ((s1[k] + 2.0 * s3) / 3.0 - u[k])).abs() < 1e-6 * s3,
                "{name} row {k}: p' {} σ1 {} u {}",
                p[k],
                s1[k],
                u[k]
            );
        }
        assert!(u[0].abs() < 0.02 * s3, "{name}: consolidated at σ3 on every wall, u starts at {}", u[0]);
        let (u_end, p_end) = (u[u.len() - 1], p[p.len() - 1]);
        if name == "loose" {
            assert!(u.iter().cloned().fold(f64::MIN, f64::max) > 0.9 * s3, "the loose packing did not liquefy: {u:?}");
            assert!(p_end < 0.3 * s3, "the loose packing kept p' {p_end}");
        } else {
            assert!(u_end < 0.0 && p_end > 2.0 * s3, "the dense packing did not dilate: u {u_end}, p' {p_end}");
        }
    }
    let phi = metrics(&dir.join("out"))["dense_phi_eff"];
    assert!((30.0..50.0).contains(&phi), "dense φ' {phi}°");
    // A 2D box has two side walls, too few to hold a volume: refused before any work.
    let plate = "b.sample_w = 0.006; b.sample_l = 0; b.sample_h = 0.006;";
    let e = refused(&dir, "undrained2d", plate, r#"triaxial(d, #{ confining: 50e3, pore_fluid: "undrained" });"#);
    assert!(e.contains("runs on a 3D box sample"), "{e}");
}

// MatDEM's 2D biaxial test (`biaxial`, the membrane as the plate's two sides): a 2D box of 334
// discs, its side walls removed once the membrane holds it, consolidated and sheared to 5 %.
// Every row: σ3 on the sides within 2 %, every cell touched or covered, quasi-static; q starts
// near 0 and rises. Measured: peak q 67 kPa at 1.5 % (σ3 50 kPa), φ 23.7°, 5 s.
#[test]
fn a_2d_biaxial_test_holds_the_cell_pressure_on_the_plates_sides() {
    let dir = temp_dir("biaxial");
    let script = r#"
let b = new_box("t");
b.sample_w = 0.012; b.sample_l = 0.0; b.sample_h = 0.024;
b.ball_r = 0.4e-3; b.distri_rate = 0.3; b.seed = 7;
b.set_type("top_platen");
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("sand", #{ kn: 2e5, ks: 8e4, mu_p: 0.5, r: 0.4e-3, restitution: 0.5, density: 2650.0 }));
d.enable("rotation");
d.set_standard_dt();
sediment(d, #{ accel: 30.0, tolerance: 0.05 });
let r = biaxial(d, #{ confining: 50e3, strain: 0.05, points: 20, tolerance: 0.05 });
r.curve.save("biaxial.csv");
report("walls", d.boundaries.len());
report("peak_q", r.peak_q);
print(d.plan());
"#;
    let o = run_script(&dir, "biaxial.rhai", script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = dir.join("out/biaxial.csv");
    for side in csv_column(&csv, "side_stress") {
        assert!((side - 50e3).abs() < 0.02 * 50e3, "side stress {side} Pa");
    }
    assert!(csv_column(&csv, "covered").iter().all(|&c| c > 0.98));
    assert!(csv_column(&csv, "unbalanced_ratio").iter().skip(1).all(|&u| u < 0.15));
    let q = csv_column(&csv, "q");
    assert!(q[0].abs() < 0.05 * 50e3, "q at the start {}", q[0]);
    let m = metrics(&dir.join("out"));
    assert!(m["peak_q"] > 0.2 * 50e3, "{m:?}");
    // The side walls went; the platens stay.
    assert_eq!(m["walls"], 2.0, "{m:?}");
    assert!(stdout(&o).contains("24 bands × 2 sectors"), "{}", stdout(&o));
    // A 3D model is refused by name.
    let e = refused(&dir, "biaxial3d", CYLINDER, "biaxial(d, #{ confining: 50e3 });");
    assert!(e.contains("for a 3D cylinder use triaxial"), "{e}");
}
