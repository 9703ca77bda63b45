//! Error reports as a user sees them: file:line:column, the source line, a caret, and a
//! non-zero exit. Checked as snapshots (with the temporary path normalised).

use crate::common::*;

fn report(name: &str, script: &str) -> (i32, String) {
    let dir = temp_dir(name);
    let o = run_script(&dir, "s.rhai", script, &[]);
    let err = stderr(&o).replace(&dir.join("s.rhai").display().to_string(), "s.rhai");
    // Drop the backend line; keep the report.
    let err: String = err.lines().filter(|l| !l.starts_with("backend:")).map(|l| format!("{l}\n")).collect();
    (o.status.code().unwrap_or(-1), err)
}

#[test]
fn syntax_error_points_at_line_and_column() {
    let (code, err) = report("syntax", "let a = 1;\nlet b = (a + ;\n");
    assert_eq!(code, 1);
    assert_eq!(
        err,
        "error: Syntax error: Unexpected ';'\n  ┌─ s.rhai:2:14\n  │\n2 │ let b = (a + ;\n  │              ^\n"
    );
}

#[test]
fn unknown_function_names_it_with_caret() {
    let (code, err) = report("unknown_fn", "let b = new_box(\"x\");\nb.buld_initial_model();\n");
    assert_eq!(code, 1);
    assert!(err.starts_with("error: Function not found: buld_initial_model (Box)"), "{err}");
    assert!(err.contains("s.rhai:2:3\n  │\n2 │ b.buld_initial_model();\n  │   ^\n"), "{err}");
    assert!(
        err.contains("  = help: did you mean `build_initial_model`? `b.build_initial_model() -> Model`\n"),
        "{err}"
    );
}

/// A MatDEM user writes MatDEM's names: the report says what they are called here.
#[test]
fn matdem_names_are_answered_with_ours() {
    let (code, err) = report("matdem_names", "let b = new_box(\"x\");\nb.sampleW = 0.01;\n");
    assert_eq!(code, 1);
    assert!(
        err.ends_with("  │   ^\n  = help: MatDEM's `sampleW` is `sample_w` here (a property of Box (read, set))\n"),
        "{err}"
    );
    let (_, err) = report(
        "matdem_calls",
        "let b = new_box(\"x\");\nlet d = b.build_initial_model();\nd.setGroupMat(\"sample\", 1);\n",
    );
    assert!(
        err.contains("= help: MatDEM's `setGroupMat` is `set_group_mat` here: `d.set_group_mat(group, material)`"),
        "{err}"
    );
    // MATLAB's single-quoted strings, caught while parsing.
    let (_, err) = report("matdem_quotes", "let d = 1;\nd.balance('Standard');\n");
    assert!(
        err.ends_with("  = help: strings take double quotes here: \"Standard\" (single quotes hold one character)\n"),
        "{err}"
    );
    // A known name called with other arguments: how it is called.
    let (_, err) = report("wrong_arguments", "let b = new_box(\"x\");\nb.set_type(3);\n");
    assert!(
        err.contains("= help: `set_type` is called as `b.set_type(\"top_platen\")` (it was given (Box, i64))"),
        "{err}"
    );
}

#[test]
fn bad_parameter_says_what_to_do_instead() {
    let (code, err) = report(
        "bad_param",
        "let m = material(\"rock\", #{ E: 2e10, nu: 0.25, Tu: 5e6, Cu: 5e7, mu_i: 0.6, d: 1e-3 });\n",
    );
    assert_eq!(code, 1);
    assert!(err.contains("ν ≤ 0.2"), "{err}");
    assert!(err.contains("Ks would be negative"), "{err}");
    assert!(err.contains("s.rhai:1:9"), "{err}");
}

#[test]
fn unknown_material_key_suggests_the_right_one() {
    let (_, err) =
        report("bad_key", "let m = material(\"rock\", #{ E: 2e10, nuu: 0.1, Cu: 5e7, mu_i: 0.6, d: 1e-3 });\n");
    assert!(err.contains("unknown material key `nuu` (did you mean `nu`?)"), "{err}");
}

#[test]
fn unstable_time_step_reports_particle_critical_step_and_fix() {
    let script = r#"
let b = new_box("u");
b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
let d = b.build_initial_model();
d.dt = d.critical_dt() * 10.0;
d.run(100);
"#;
    let (code, err) = report("unstable", script);
    assert_eq!(code, 1);
    assert!(err.starts_with("error: unstable at step 0: particle "), "{err}");
    assert!(err.contains("critical time step"), "{err}");
    assert!(err.contains("Fix: use the standard time step"), "{err}");
    assert!(err.contains("s.rhai:6:3"), "{err}");
}

#[test]
fn error_inside_stdlib_shows_the_call_site_in_the_script() {
    let (code, err) = report("stdlib_err", "let t = new_table();\nstage_load(t, \"top\", 1.0, #{});\n");
    assert_eq!(code, 1);
    assert!(err.contains("in call to `stage_load`"), "{err}");
    assert!(err.contains("s.rhai:2:1"), "{err}");
}

#[test]
fn missing_script_exits_2() {
    let o = bin().args(["run", "/nonexistent/x.rhai"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("cannot read script /nonexistent/x.rhai"));
}

#[test]
fn output_outside_the_run_folder_is_refused() {
    let (code, err) = report("escape", "let t = new_table();\nt.add_row(#{a: 1});\nt.save(\"../x.csv\");\n");
    assert_eq!(code, 1);
    assert!(err.contains("outside the allowed folders"), "{err}");
}

/// A misspelt variable gets the nearest name the script made; a misspelt stdlib module the
/// nearest module and the list of them.
#[test]
fn a_misspelt_variable_or_stdlib_module_gets_the_nearest_name() {
    let (code, err) = report("misspelt_variable", "let sample = 3;\nprint(sampel);\n");
    assert_eq!(code, 1);
    assert!(err.starts_with("error: Variable not found: sampel\n"), "{err}");
    assert!(err.ends_with("  │       ^\n  = help: did you mean `sample`?\n"), "{err}");
    let (code, err) = report("misspelt_module", "import \"std/oedometr\" as o;\n");
    assert_eq!(code, 1);
    assert!(
        err.contains("no stdlib module is called `std/oedometr` (did you mean `std/oedometer`?): the stdlib's are"),
        "{err}"
    );
}

/// A small box `d` with a top platen, a material and the standard time step: five lines.
const SMALL_BOX: &str = "let b = new_box(\"x\");\nb.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; \
                         b.ball_r = 0.5e-3; b.set_type(\"top_platen\");\nlet d = b.build_initial_model();\n\
                         d.set_group_mat(\"sample\", material_micro(\"m\", #{ kn: 2e5, ks: 8e4, mu_p: 0.3, r: 0.5e-3 \
                         }));\nd.set_standard_dt();\n";

/// A stdlib procedure refuses an option it does not read, naming the nearest: before, a typo
/// was dropped without a word (`max_step: 100` ran the default 200,000 steps).
#[test]
fn a_misspelt_option_of_a_stdlib_procedure_is_refused() {
    let (code, err) = report("misspelt_option", &format!("{SMALL_BOX}sediment(d, #{{ max_step: 100 }});\n"));
    assert_eq!(code, 1);
    assert!(err.starts_with("error: sediment: unknown option `max_step` (did you mean `max_steps`?)"), "{err}");
    assert!(err.contains("  = in call to `sediment`\n"), "{err}");
    // An option a procedure passes on to another is its own too: compact's `tolerance` is
    // stage_load's, and stage_load is not handed compact's `local_damping`.
    let script = format!(
        "{SMALL_BOX}compact(d, 1e3, #{{ local_damping: 0.7, tolerance: 0.5, max_steps: 200 }});\n\
         compact(d, 1e3, #{{ tolerence: 0.5 }});\n"
    );
    let (_, err) = report("forwarded_option", &script);
    assert!(err.starts_with("error: compact: unknown option `tolerence` (did you mean `tolerance`?)"), "{err}");
    assert!(err.contains("7 │ compact(d, 1e3, #{ tolerence: 0.5 });"), "{err}");
}

/// Native functions that read an options map refuse a key they do not read, as the stdlib
/// procedures do: before, `test_sample`, `lab_test`, `anova` and `least_squares` dropped it.
#[test]
fn a_misspelt_option_of_a_native_function_is_refused() {
    let m = "let m = material(\"rock\", #{ E: 2e10, nu: 0.15, Tu: 5e6, Cu: 5e7, mu_i: 0.6, d: 1e-3 });\n";
    let (_, err) = report("misspelt_sample", &format!("{m}test_sample(m, #{{ element: 50 }});\n"));
    assert!(err.starts_with("error: test_sample: unknown key `element` (did you mean `elements`?)"), "{err}");
    let (_, err) = report(
        "misspelt_material_test",
        // Refused before the sample is used: no sample needs packing for the check.
        "uniaxial_compression((), #{ steps_to_pk: 100 });\n",
    );
    assert!(
        err.starts_with("error: uniaxial_compression: unknown option `steps_to_pk` (did you mean `steps_to_peak`?)"),
        "{err}"
    );
    let (_, err) = report("misspelt_anova", "let d = orthogonal_design([\"a\", \"b\"], [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]]);\nanova(d, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], #{ pol: 1 });\n");
    assert!(err.starts_with("error: anova: unknown key `pol` (did you mean `pool`?)"), "{err}");
    let (_, err) = report("misspelt_least_squares", "least_squares(|p| [p[0] - 1.0], [0.0], #{ max_iteration: 5 });\n");
    assert!(
        err.starts_with("error: least_squares: unknown key `max_iteration` (did you mean `max_iterations`?)"),
        "{err}"
    );
}

/// A step count written as MatDEM writes it (1e3, a float in Rhai) runs that many steps; a
/// count that is not whole is refused.
#[test]
fn a_whole_float_is_a_step_count_and_a_fraction_is_refused() {
    let (code, err) = report(
        "float_steps",
        &format!("{SMALL_BOX}let r = d.run(1e2);\nif r.steps != 100 || d.step != 100 {{ throw `ran ${{r.steps}}`; }}\nd.balance(5e1);\nd.run(2.5);\n"),
    );
    assert_eq!(code, 1);
    assert!(err.starts_with("error: run: steps must be a whole number of steps ≥ 0, got 2.5"), "{err}");
}
