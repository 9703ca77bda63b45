//! `matdem-rs study` end to end: every combination runs, a failing setting is recorded and
//! the others go on, errors are relative to the reference, and the table and chart are written.

use crate::common::*;

/// Reports 1/x, and refuses x = 0 the way an unstable setting would stop.
const SCRIPT: &str = r#"
if params.x == 0 { throw "x must not be 0"; }
report("inverse", 1.0 / params.x + params.offset);
"#;

#[test]
fn study_runs_every_setting_and_measures_error_against_the_reference() {
    let dir = temp_dir("study_cli");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, SCRIPT).unwrap();
    let out = dir.join("out");
    let o = bin()
        .args(["study"])
        .arg(&script)
        .args([
            "--vary",
            "x=0,1,2,4",
            "--vary",
            "offset=0.0,1.0",
            "--metric",
            "inverse",
            "--reference",
            "x=4,offset=0.0",
        ])
        .args(["--backend", "cpu", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "stderr:\n{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("study.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(csv.lines().next(), Some("run,x,offset,wall_s,inverse,rel_error,reference,note"));
    assert_eq!(rows.len(), 8, "{csv}");
    // x = 0 failed with the script's own message, and the study went on.
    assert_eq!(rows[0][4], "", "{csv}");
    assert!(rows[0][7].contains("x must not be 0"), "{csv}");
    // x = 2, offset 0: 0.5 against the reference 0.25 is an error of 100 %.
    let row = rows.iter().find(|r| r[1] == "2" && r[2] == "0.0").unwrap();
    assert_eq!(row[4].parse::<f64>().unwrap(), 0.5);
    assert!((row[5].parse::<f64>().unwrap() - 1.0).abs() < 1e-12, "{csv}");
    let reference = rows.iter().find(|r| r[6] == "true").unwrap();
    assert_eq!((reference[1], reference[2], reference[5]), ("4", "0.0", "0.0"));
    for f in ["study.svg", "study.png", "run01/log.txt", "run08/metrics.csv"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn study_of_a_metric_the_script_never_reports_says_which_it_did() {
    let dir = temp_dir("study_cli_missing");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, SCRIPT).unwrap();
    let o = bin()
        .args(["study"])
        .arg(&script)
        .args(["--vary", "x=1,2", "--set", "offset=0.0", "--metric", "strain", "--backend", "cpu", "--out"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains("did not report `strain`; it reported: inverse"), "{err}");
    assert!(err.contains("no run gave a result"), "{err}");
}

// `--vary backend=cpu,gpu` (Mesa's software Vulkan in CI): both settings run the same script
// and report the same settled height within 1e-3 relative, and the table names the backends.
#[test]
fn study_varies_the_backend_between_the_cpu_and_the_gpu() {
    let dir = temp_dir("study_backend");
    let script = dir.join("drop.rhai");
    std::fs::write(
        &script,
        r#"
        let b = new_box("drop");
        b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
        let d = b.build_initial_model();
        d.gravity = [0.0, 0.0, -9.81];
        d.set_standard_dt();
        d.balance("standard");
        report("zmean", d.z.mean());
        "#,
    )
    .unwrap();
    let out = dir.join("out");
    let o = bin()
        .arg("study")
        .arg(&script)
        .args(["--vary", "backend=cpu,gpu", "--metric", "zmean", "--reference", "backend=cpu", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "stderr:\n{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("study.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2, "{csv}");
    assert_eq!((rows[0][1], rows[1][1]), ("cpu", "gpu"), "{csv}");
    if rows[1][3].is_empty() && !gpu_required() {
        eprintln!("skipped: no GPU adapter: {csv}");
        return;
    }
    let err: f64 = rows[1][4].parse().unwrap_or_else(|_| panic!("{csv}"));
    assert!(err < 1e-3, "{csv}");
}
