//! Hardening II (issue 28), "messages that mislead": each bad input is refused where it is
//! given, naming the input (not a value derived from it) and what to do instead. Each case's
//! comment gives what was said (or accepted) before.

use crate::common::*;
use std::process::{Output, Stdio};

/// Runs `script` and returns its stderr, asserting that it failed.
fn refused(dir: &std::path::Path, script: &str) -> String {
    let o = run_script(dir, "t.rhai", script, &["--backend", "cpu"]);
    assert!(!o.status.success(), "accepted:\n{script}\n{}", stderr(&o));
    stderr(&o)
}

const BOX: &str = r#"let d = new_model("m");
d.add_elements(make_box(0.01, 0.01, 0.01, 1e-3), material_micro("g", #{ kn: 1e5, r: 1e-3 }), "a");
"#;

#[test]
fn bad_material_values_are_named_as_given() {
    let dir = temp_dir("msg_material");
    let macro_ =
        |e: &str, tu: &str| format!("material(\"x\", #{{ E: {e}, nu: 0.1, Tu: {tu}, Cu: 1e7, mu_i: 0.5, d: 1e-3 }});");
    // Before: "`xb` = inf must be ≥ 0".
    let e = refused(&dir, &macro_("1e-300", "1e6"));
    assert!(e.contains("`E` = 1e-300") && e.contains("give E in Pa"), "{e}");
    // Before: accepted, with Xb = 0 (bonds that break at any tension).
    let e = refused(&dir, &macro_("1e300", "1e6"));
    assert!(e.contains("`E` = 1e300"), "{e}");
    // Before: accepted.
    let e = refused(&dir, &macro_("1e10", "1e8"));
    assert!(e.contains("`Tu`") && e.contains("above Cu"), "{e}");
    // Before: "`kn` = -3.14e6 must be > 0" (Kn derived from E).
    let e = refused(&dir, r#"material_micro("x", #{ young: -1e9, poisson: 0.2, r: 1e-3 });"#);
    assert!(e.contains("`young` = -1000000000 Pa") && !e.contains("`kn`"), "{e}");
}

#[test]
fn a_standard_step_from_absurd_radii_names_the_particle_not_a_silent_zero() {
    let dir = temp_dir("msg_dt");
    for r in ["5e-321", "1e300"] {
        // Before: set_standard_dt() set a zero (or infinite) step without a word.
        let script = format!(
            "let d = new_model(\"m\"); let t = new_table(); t.add_row(#{{ x: 0.0, y: 0.0, z: 0.0, r: {r} }});
             d.add_elements(t, material_micro(\"g\", #{{ kn: 1e5, r: 1e-3 }}), \"a\"); d.set_standard_dt();"
        );
        let e = refused(&dir, &script);
        assert!(e.contains("standard time step comes out as") && e.contains("particle 0"), "{r}: {e}");
    }
}

#[test]
fn field_settings_outside_physics_are_refused_where_given() {
    let dir = temp_dir("msg_fields");
    // Before: accepted.
    let e = refused(&dir, &format!("{BOX} d.enable(\"heat\"); d.temperature = -10.0;"));
    assert!(e.contains("-10 K, below absolute zero"), "{e}");
    let e = refused(&dir, &format!("{BOX} d.enable(\"heat\"); d.reference_temperature = -1.0;"));
    assert!(e.contains("below absolute zero"), "{e}");
    // Before: accepted, and the run stopped later with "loaded contacts are stiffer".
    let e = refused(&dir, &format!("{BOX} d.enable(\"heat\"); d.thermal(\"g\", #{{ expansion: 1e-2 }});"));
    assert!(e.contains("`expansion` = 0.01 /K") && e.contains("linear expansion coefficient"), "{e}");
    // Before: accepted, then "pore 0's pressure is not finite" at the first step.
    let e = refused(
        &dir,
        r#"let d = new_model("m");
           d.add_elements(make_disc(0.01, 1e-3), material_micro("g", #{ kn: 1e5, r: 1e-3 }), "a");
           d.enable("pore_flow");"#,
    );
    assert!(e.contains("one plane") && e.contains("pore flow"), "{e}");
}

#[test]
fn elements_added_twice_are_named_before_the_run_not_as_a_non_finite_position() {
    let dir = temp_dir("msg_coincident");
    // Before: "particle 22 has a non-finite position, velocity or force".
    let e = refused(
        &dir,
        r#"let d = new_model("m");
           let m = material_micro("g", #{ kn: 1e5, r: 1e-3 });
           let g = make_box(0.01, 0.01, 0.01, 1e-3);
           d.add_elements(g, m, "a"); d.add_elements(g, m, "b");
           d.set_standard_dt(); d.run(10);"#,
    );
    assert!(e.contains("sit at the same place") && e.contains("added twice"), "{e}");
}

fn cli(args: &[&str], dir: &std::path::Path) -> Output {
    bin().current_dir(dir).args(args).stdin(Stdio::null()).output().unwrap()
}

#[test]
fn command_line_mistakes_are_worded_for_what_they_are() {
    let dir = temp_dir("msg_cli");
    std::fs::write(dir.join("t.rhai"), "report(\"m\", 1.0);").unwrap();
    // Before: "a word Rhai reserves".
    for name in ["a b", "../x", "a,b"] {
        let o = cli(&["run", "t.rhai", "--set", &format!("{name}=1")], &dir);
        assert!(stderr(&o).contains("is not a name a script can write"), "{name}: {}", stderr(&o));
    }
    // Before: "is not a whole number".
    let o = cli(&["run", "t.rhai", "--max-operations", "99999999999999999999999"], &dir);
    assert!(stderr(&o).contains("is too large"), "{}", stderr(&o));
    // Before: "0 would switch the limit off".
    let o = cli(&["sweep", "run", "sw", "--local", "-j", "0"], &dir);
    assert!(stderr(&o).contains("0 would run nothing"), "{}", stderr(&o));
    // Before: accepted, every point failing later.
    let o = cli(&["sweep", "plan", "t.rhai", "--out", "sw", "--vary", "backend=quantum"], &dir);
    assert!(stderr(&o).contains("backend `quantum` is not one"), "{}", stderr(&o));
    assert!(cli(&["sweep", "plan", "t.rhai", "--out", "sw", "--vary", "x=1,2"], &dir).status.success());
    // Before: both accepted and written into the job script.
    let o = cli(&["sweep", "slurm", "sw", "--cpus-per-task", "0"], &dir);
    assert!(stderr(&o).contains("--cpus-per-task 0"), "{}", stderr(&o));
    let o = cli(&["sweep", "slurm", "sw", "--time", "abc"], &dir);
    assert!(stderr(&o).contains("is not a Slurm time"), "{}", stderr(&o));
    // Before: "File exists".
    std::os::unix::fs::symlink("/nonexistent/matdem", dir.join("dangling")).unwrap();
    let o = cli(&["run", "t.rhai", "--out", "dangling"], &dir);
    assert!(stderr(&o).contains("is a symbolic link to /nonexistent/matdem, which does not exist"), "{}", stderr(&o));
    // Before: every point ran, then the study complained.
    let o = cli(&["study", "t.rhai", "--vary", "x=1,2", "--metric", "../x", "--out", "st"], &dir);
    assert!(stderr(&o).contains("--metric: metric name `../x`"), "{}", stderr(&o));
    assert!(!dir.join("st").exists());
    // Before: "unknown command `:load`".
    let o = bin()
        .current_dir(&dir)
        .args(["repl", "--out", "r"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            use std::io::Write;
            c.stdin.take().unwrap().write_all(b":load\n:quit\n")?;
            c.wait_with_output()
        })
        .unwrap();
    let text = format!("{}{}", stdout(&o), stderr(&o));
    assert!(text.contains(":load needs a file"), "{text}");
}

// Before: `d.heat_substeps = 4000000000` (or a forged checkpoint's) made one step run for
// hours without hearing a signal.
#[test]
fn sub_step_counts_past_the_bound_are_refused() {
    let dir = temp_dir("msg_substeps");
    let e = refused(&dir, &format!("{BOX} d.enable(\"heat\"); d.heat_substeps = 4000000000;"));
    assert!(e.contains("heat_substeps must be an integer from 1 to 1000000"), "{e}");
    let e = refused(&dir, &format!("{BOX} d.fluid = #{{ max_substeps: 4000000000 }};"));
    assert!(e.contains("max_substeps"), "{e}");
}
