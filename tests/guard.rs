//! The stability guard as a user meets it (issue 11 item 6, issue 18 item 13): a loading
//! step too long for the loaded sample stops with the contact, its stiffness, its critical
//! step and the fix named — or, with `d.guard = "warn"`, warns once and goes on — the
//! standard step is never flagged, and a gravity that flings particles is named as the cause
//! instead of dt.

use crate::common::*;
use std::path::{Path, PathBuf};

fn oedometer() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/oedometer")
}

/// `matdem-rs run <package> --set quick=true --set samples=<samples> --set dt_rate=<rate>`.
fn run_quick(package: &Path, name: &str, samples: &str, rate: &str) -> std::process::Output {
    let out = temp_dir(name);
    bin()
        .arg("run")
        .arg(package)
        .args(["--backend", "cpu", "--out"])
        .arg(&out)
        .args(["--set", "quick=true", "--set", &format!("samples={samples}"), "--set", &format!("dt_rate={rate}")])
        .output()
        .unwrap()
}

// The quick oedometer loads at 4× and 5× the standard step: before, both finished "ok" (void
// ratio at 50 kPa 1.027 and 0.690 against 1.042 at 1× and 3×; coordination 3.2 and 4.0
// against 4.4). The stiffest contact is a small grain's shear spring on a wall: dt is 0.83
// and 1.05 of its critical step; the guard allows 0.7 (3× is at 0.63).
#[test]
fn the_4x_oedometer_step_is_caught() {
    for rate in ["4", "5"] {
        let o = run_quick(&oedometer(), &format!("guard_oedometer_{rate}x"), "1", rate);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "dt_rate {rate} must stop: {err}");
        assert!(err.contains("error: unstable at step "), "{err}");
        // The contact: a particle and the other body (a wall here), the spring and its stiffness.
        let named = err.contains("is in the stiffest contact, with wall `") || err.contains("with particle ");
        assert!(named, "names the contact: {err}");
        assert!(err.contains("shear spring is 8.386e5 N/m"), "names the stiffness: {err}");
        assert!(err.contains("critical step √(2m/k) of "), "names the critical step: {err}");
        assert!(err.contains("Fix: set dt ≤ ") && err.contains("(d.dt = "), "names the fix: {err}");
        assert!(err.contains("call set_standard_dt() after loading"), "{err}");
    }
}

// Deposited and loaded to 3.2 MPa at the standard step (the widest gradation, three size
// classes; samples 1 and 2 run in cli.rs and packages.rs), and at 3×: nothing is flagged.
#[test]
fn the_standard_step_is_not_flagged() {
    for (samples, rate) in [("3", "1"), ("1", "3")] {
        let o = run_quick(&oedometer(), &format!("guard_standard_{samples}_{rate}"), samples, rate);
        let err = stderr(&o);
        assert!(o.status.success(), "sample {samples} at dt_rate {rate}: {err}");
        assert!(!err.contains("stiffest contact"), "{err}");
    }
}

// The same 4× run with `d.guard = "warn"`: one warning, and the run finishes.
#[test]
fn guard_warn_mode_warns_once_and_goes_on() {
    let dir = temp_dir("guard_warn_package");
    for f in ["simulator.ron", "compress.rhai"] {
        std::fs::copy(oedometer().join(f), dir.join(f)).unwrap();
    }
    let script = std::fs::read_to_string(dir.join("compress.rhai")).unwrap();
    let law = "    d.contact_law = \"hertz\";\n";
    assert!(script.contains(law));
    std::fs::write(dir.join("compress.rhai"), script.replace(law, &format!("{law}    d.guard = \"warn\";\n"))).unwrap();
    let o = run_quick(&dir, "guard_warn_out", "1", "4");
    let err = stderr(&o);
    assert!(o.status.success(), "warn mode goes on: {err}");
    assert_eq!(err.matches("warning: unstable at step").count(), 1, "warns once: {err}");
    assert!(err.contains("is in the stiffest contact"), "{err}");
}

#[test]
fn an_unknown_guard_mode_lists_the_known_ones() {
    let dir = temp_dir("guard_mode");
    let script = "let b = new_box(\"g\");\nb.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = \
                  0.5e-3;\nlet d = b.build_initial_model();\nd.guard = \"wran\";\n";
    let o = run_script(&dir, "s.rhai", script, &["--backend", "cpu"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("unknown guard mode `wran` (did you mean `warn`?)"), "{err}");
}

// Issue 18 item 13: gravity 1e12 used to be blamed on dt ("halve dt").
#[test]
fn absurd_gravity_is_named_as_the_cause_not_dt() {
    let dir = temp_dir("guard_gravity");
    let script = "let b = new_box(\"g\");\nb.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = \
                  0.5e-3;\nlet d = b.build_initial_model();\nd.set_standard_dt();\nd.gravity = [0.0, 0.0, \
                  -1e12];\nd.run(100);\n";
    let o = run_script(&dir, "s.rhai", script, &["--backend", "cpu"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("error: gravity is the cause: |g| = 1.000e12 m/s²"), "{err}");
    assert!(err.contains("A sensible gravity is 9.81 m/s²") && err.contains("it must stay under"), "{err}");
    assert!(err.contains("Fix: set d.gravity to a sensible value"), "{err}");
    assert!(!err.contains("halve dt ("), "{err}");
    assert!(err.contains("s.rhai:6:3"), "points at the run: {err}");
}
