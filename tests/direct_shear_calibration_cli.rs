//! Paper 002's calibration example (examples/direct_shear_calibration) in quick mode through
//! the CLI: the design's rows run as child runs, the ANOVA, charts, regressions, the inversion
//! and the confirmation runs are written; and `run_points`, which runs the rows: points
//! get their parameters and the run's own, report back, are not run twice, and cannot nest.

use crate::common::*;

#[test]
fn calibration_quick_mode_runs_the_design_in_parallel_and_confirms_the_inversion() {
    let dir = temp_dir("direct_shear_calibration_quick");
    let out = dir.join("out");
    let (log, wall) = run_example_quick("direct_shear_calibration", &out);
    eprintln!("direct_shear_calibration quick mode: {wall:.1} s wall\n{log}");

    for name in ["effects_tau", "effects_c", "effects_phi", "f_tau", "f_c", "f_phi", "confirm_errors"] {
        for ext in ["svg", "png"] {
            let f = out.join(format!("{name}.{ext}"));
            let len = std::fs::metadata(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display())).len();
            assert!(len > 1000, "{} is only {len} bytes", f.display());
        }
    }
    for f in [
        "design.csv",
        "rows.csv",
        "anova_tau.csv",
        "anova_c.csv",
        "anova_phi.csv",
        "confirm.csv",
        "confirm_seeds.csv",
        "noise.csv",
        "regressions.csv",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // The reduced design: nine rows, each a run of its own with its three shears.
    for k in 1..=9 {
        let row = out.join(format!("points/run{k:02}"));
        for s in ["100", "200", "300"] {
            assert!(row.join(format!("shear_{s}.0kPa.csv")).is_file(), "{} lacks its {s} kPa shear", row.display());
        }
    }
    let rows = std::fs::read_to_string(out.join("rows.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 9, "{rows}");
    // The weakest effect is pooled into the error (the L9's four factors fill its 8 dof).
    let anova = std::fs::read_to_string(out.join("anova_tau.csv")).unwrap();
    assert!(anova.contains("(pooled)"), "no pooled effect:\n{anova}");

    let m = metrics(&out);
    let get = |k: &str| *m.get(k).unwrap_or_else(|| panic!("metric {k} missing: {m:?}"));
    assert_eq!(get("rows"), 9.0);
    // The noise floor: the reference row on quick mode's two packings.
    assert_eq!(get("seeds"), 2.0);
    assert_eq!(std::fs::read_to_string(out.join("noise.csv")).unwrap().lines().count(), 1 + 2);
    for k in ["noise_tau_sd", "noise_c_sd", "noise_phi_sd"] {
        assert!(get(k).is_finite() && get(k) >= 0.0, "{m:?}");
    }
    // Confirmation rounds: one row per round in confirm.csv, one per packing and round in
    // confirm_seeds.csv; the loop stops when the goal is met or at quick mode's cap of 2.
    let rounds = get("rounds");
    assert!((1.0..=2.0).contains(&rounds), "{m:?}");
    assert_eq!(csv_column(&out.join("confirm.csv"), "round").len(), rounds as usize);
    assert_eq!(csv_column(&out.join("confirm_seeds.csv"), "seed").len(), 2 * rounds as usize);
    let errs = ["err_tau_pct", "err_c_pct", "err_phi_pct"].map(|k| get(k).abs());
    assert_eq!(get("goal_met") == 1.0, errs.iter().all(|e| *e <= 10.0), "{m:?}");
    assert!(get("goal_met") == 1.0 || rounds == 2.0, "stopped before the cap without meeting the goal: {m:?}");
    // The servo held the normal stress: each row's mean within 1 % of its target in every
    // shear of every confirmation run (single checks, every 2 steps, scatter by a few %).
    for e in csv_column(&out.join("confirm_seeds.csv"), "sigma_err_pct") {
        assert!(e < 1.0, "a row mean of the normal stress {e} % off its target");
    }
    // Strengths of a bonded loess sample: positive and finite; the errors are measured.
    assert!(get("tau_kpa") > 0.0 && get("tau_kpa") < 1000.0, "{m:?}");
    assert!(get("phi_deg") > 0.0 && get("phi_deg") < 70.0, "{m:?}");
    for e in ["err_tau_pct", "err_c_pct", "err_phi_pct", "c_kpa"] {
        assert!(get(e).is_finite(), "{m:?}");
    }
    // The inverted parameters lie in the design's range.
    assert!((0.3..=0.7).contains(&get("lambda")) && (0.1..=0.9).contains(&get("mu")), "{m:?}");
    assert!((100e3..=500e3).contains(&get("sigma_c")), "{m:?}");
    assert!(get("design_wall_s") > 0.0 && get("design_wall_s") < get("wall_time"), "{m:?}");
}

const POINTS: &str = r#"
if (params.mode ?? "") == "point" {
    report("twice", params.v * 2.0);
    report("common", params.common);
    if params.nest ?? false {
        run_points([#{ v: 1.0 }], #{});
    }
    return;
}
let out = run_points([#{ mode: "point", v: 1.5 }, #{ mode: "point", v: 4.0 }], #{ jobs: 2, folder: "pts" });
for o in out {
    print(`${o.name} ok=${o.ok} twice=${o.metrics.twice} common=${o.metrics.common}`);
}
let bad = run_points([#{ mode: "point", v: 1.0, nest: true }], #{ folder: "nested" });
print(`nested ok=${bad[0].ok} error=${bad[0].error}`);
"#;

#[test]
fn run_points_runs_the_script_at_each_parameter_set_once_and_refuses_to_nest() {
    let dir = temp_dir("run_points");
    let o = run_script(&dir, "points.rhai", POINTS, &["--set", "common=7"]);
    let (out, err) = (stdout(&o), stderr(&o));
    assert!(o.status.success(), "{out}\n{err}");
    // Each point got its own parameters and the run's own (common=7).
    assert!(out.contains("run01 ok=true twice=3.0 common=7.0"), "{out}\n{err}");
    assert!(out.contains("run02 ok=true twice=8.0 common=7.0"), "{out}\n{err}");
    assert!(dir.join("out/pts/run01/metrics.csv").is_file() && dir.join("out/pts/sweep.ron").is_file());
    // A point that starts points of its own fails with the reason, and the caller sees it.
    assert!(out.contains("nested ok=false") && out.contains("a point cannot start runs of its own"), "{out}\n{err}");

    // Run again into the same folder: the finished points are not run again.
    let o = run_script(&dir, "points.rhai", POINTS, &["--set", "common=7"]);
    let (out, err) = (stdout(&o), stderr(&o));
    assert!(o.status.success(), "{out}\n{err}");
    assert!(err.contains("finished already; nothing to run"), "{err}");
    assert!(out.contains("run02 ok=true twice=8.0 common=7.0"), "{out}");
}

#[test]
fn run_points_refuses_unknown_options_and_points_that_are_not_maps() {
    let dir = temp_dir("run_points_refusals");
    let o = run_script(&dir, "a.rhai", "run_points([#{ v: 1 }], #{ job: 2 });", &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("unknown option `job`; options: jobs, folder"), "{}", stderr(&o));
    let o = run_script(&dir, "b.rhai", "run_points([1, 2], #{});", &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("point 1 must be a map of parameters"), "{}", stderr(&o));
}
