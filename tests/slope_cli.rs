//! The slope example (examples/slope) in quick mode through the CLI: MatDEM's three steps end
//! to end — deposit, cut from terrain points, two layers, a weak joint, strength reduction to
//! failure — writing its charts and pictures, with a finite positive run-out and the joint's
//! bonds breaking more often, per bond, than the rest (counted by the script from
//! `d.breakages()`, not assumed).

use crate::common::*;

#[test]
fn slope_quick_mode_slides_along_the_joint_and_writes_its_charts() {
    let dir = temp_dir("slope_quick");
    let out = dir.join("out");
    let (log, wall) = run_example_quick("slope", &out);
    eprintln!("slope quick mode: {wall:.1} s wall\n{log}");
    check_slide(&out);
}

// MatDEM's classic 2D slope (`--set dimension=2`): the same three steps on one layer of discs in
// the x–z plane with the 2D lattice materials; it too fails at a finite factor along the joint.
// Measured: 3,026 elements, failure at F = 2.6, 32 % of the joint's bonds broken against 22 %
// elsewhere, about 40 s.
#[test]
fn the_2d_slope_fails_along_its_joint_by_strength_reduction() {
    let dir = temp_dir("slope_2d");
    let out = dir.join("out");
    let (log, wall) = run_example_quick_with("slope", &out, &["dimension=2"]);
    eprintln!("2D slope quick mode: {wall:.1} s wall\n{log}");
    check_slide(&out);
}

/// What a slope run that slid must show: its charts and pictures, a finite factor at failure,
/// a run-out, and the joint's bonds breaking first and most.
fn check_slide(out: &std::path::Path) {
    for name in [
        "displacement_vs_factor",
        "broken_bonds_vs_factor",
        "slide",
        "layers",
        "joint_wedge",
        "displacement",
        "failure_surface",
        "broken_bonds",
    ] {
        for ext in ["svg", "png"] {
            let f = out.join(format!("{name}.{ext}"));
            let len = std::fs::metadata(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display())).len();
            assert!(len > 1000, "{} is only {len} bytes", f.display());
        }
    }
    for f in ["stages.csv", "slide.csv", "metrics.csv"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }

    let m = metrics(out);
    let get = |k: &str| *m.get(k).unwrap_or_else(|| panic!("metric {k} missing: {m:?}"));
    // The slope stands under its own weight (F = 1) and fails at a finite factor.
    let f = get("factor_at_failure");
    assert!(f > 1.0 && f.is_finite(), "factor at failure {f}");
    let runout = get("runout");
    assert!(runout.is_finite() && runout > 0.0, "run-out {runout} m");
    assert!(get("max_displacement") > runout.min(1.0), "{m:?}");
    // Per bond, the joint breaks more often than the rest of the slope.
    let (bj, nj, bo, no) = (get("broken_joint"), get("joint_bonds"), get("broken_other"), get("other_bonds"));
    assert!(nj > 10.0 && no > 1000.0, "{m:?}");
    let (joint, other) = (bj / nj, bo / no);
    assert!(joint > other, "broken per bond: joint {joint:.3} ({bj} of {nj}), elsewhere {other:.3} ({bo} of {no})");

    // At every stage where anything had broken, the joint's share was the larger one: the
    // joint breaks first, not just most.
    let stages = std::fs::read_to_string(out.join("stages.csv")).unwrap();
    let mut lines = stages.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"));
    let (cj, co, cf) = (col("broken_joint_share"), col("broken_other_share"), col("factor"));
    let mut rows = 0;
    for line in lines {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        if v[cj] > 0.0 || v[co] > 0.0 {
            assert!(v[cj] > v[co], "at F = {}: joint {} ≤ elsewhere {}", v[cf], v[cj], v[co]);
        }
        rows += 1;
    }
    assert!(rows >= 2, "{stages}");
}
