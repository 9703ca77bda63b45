//! Field maths and the numbers policy from Rhai, in process: element-wise functions, no
//! NaN or infinity made silently (each refusal names the element), empty selections, porosity
//! windows, chart gaps, and CSV files quoted per RFC 4180.

use matdem_rs::api::Host;
use rhai::Dynamic;
use std::rc::Rc;

fn engine(name: &str) -> (rhai::Engine, Rc<Host>, std::path::PathBuf) {
    let dir = crate::common::temp_dir(name);
    let host = Rc::new(Host::new(dir.clone()));
    (matdem_rs::new_engine(host.clone()), host, dir)
}

fn values(name: &str, script: &str) -> Vec<f64> {
    let (engine, _, _) = engine(name);
    let f: rhai::Array =
        engine.eval(&format!("let v = {{ {script} }}; v.to_array()")).unwrap_or_else(|e| panic!("{script}: {e}"));
    f.into_iter().map(|v| v.as_float().unwrap()).collect()
}

/// The message of the script error `script` ends in.
fn refusal(name: &str, script: &str) -> String {
    let (engine, _, _) = engine(name);
    engine.eval::<Dynamic>(script).expect_err(script).to_string()
}

const SMALL_BOX: &str = r#"
let b = new_box("t");
b.sample_w = 0.003; b.sample_l = 0.003; b.sample_h = 0.002; b.ball_r = 0.4e-3; b.seed = 3;
let d = b.build_initial_model();
"#;

#[test]
fn element_wise_min_and_max_take_two_fields_or_a_field_and_a_number() {
    let a = "field([1.0, -2.0, 3.0])";
    assert_eq!(values("min_ff", &format!("min({a}, field([0.0, 0.0, 5.0]))")), [0.0, -2.0, 3.0]);
    assert_eq!(values("max_fn", &format!("max({a}, 0.5)")), [1.0, 0.5, 3.0]);
    assert_eq!(values("max_nf", &format!("max(0, {a})")), [1.0, 0.0, 3.0]);
    assert_eq!(values("min_method", &format!("{a}.min(2)")), [1.0, -2.0, 2.0]);
    // The reductions keep working beside them.
    let (engine, _, _) = engine("min_reduce");
    assert_eq!(engine.eval::<f64>(&format!("{a}.min() + {a}.max()")).unwrap(), 1.0);
    let e = refusal("min_len", "min(field([1.0]), field([1.0, 2.0]))");
    assert!(e.contains("different lengths (1 and 2)"), "{e}");
}

#[test]
fn clamp_bounds_each_element_and_refuses_lo_above_hi() {
    assert_eq!(values("clamp", "field([-1.0, 0.5, 9.0]).clamp(0, 1.0)"), [0.0, 0.5, 1.0]);
    let e = refusal("clamp_bad", "field([1.0]).clamp(2.0, 1.0)");
    assert!(e.contains("clamp: the bounds must be finite numbers with lo ≤ hi, got lo = 2, hi = 1"), "{e}");
}

#[test]
fn exp_ln_and_log10_work_on_whole_fields() {
    let v = values("logs", "field([1.0, 100.0]).log10() + field([1.0, 2.0]).exp().ln()");
    assert!((v[0] - 1.0).abs() < 1e-15 && (v[1] - 4.0).abs() < 1e-15, "{v:?}");
}

#[test]
fn pow_raises_a_field_to_a_number_or_to_a_field_of_exponents() {
    assert_eq!(values("pow_n", "field([2.0, 3.0]).pow(2)"), [4.0, 9.0]);
    assert_eq!(values("pow_op", "field([2.0, 3.0]) ** 0.0"), [1.0, 1.0]);
    assert_eq!(values("pow_f", "pow(field([2.0, 3.0]), field([3.0, 2.0]))"), [8.0, 9.0]);
    assert_eq!(values("pow_base", "2.0 ** field([1.0, -1.0])"), [2.0, 0.5]);
}

#[test]
fn where_picks_from_two_fields_or_numbers_by_a_mask() {
    let a = "field([1.0, -2.0, 3.0])";
    assert_eq!(values("where_fn", &format!("where({a} > 0.0, {a}, 0)")), [1.0, 0.0, 3.0]);
    assert_eq!(values("where_nn", &format!("where({a} < 0.0, -1.0, 1.0)")), [1.0, -1.0, 1.0]);
    assert_eq!(values("where_ff", &format!("where({a} > 2.0, {a} * 10.0, -{a})")), [-1.0, 2.0, 30.0]);
    let e = refusal("where_type", &format!("where({a} > 0.0, \"x\", 0)"));
    assert!(e.contains("where: expected a Field or a number, got string"), "{e}");
}

#[test]
fn the_new_field_functions_are_in_the_help_table_and_callable() {
    let (engine, _, _) = engine("help_table");
    let sigs = engine.gen_fn_signatures(false);
    for name in ["min", "max", "clamp", "abs", "sqrt", "exp", "ln", "log10", "pow", "where", "is_finite"] {
        let (usage, doc) = matdem_rs::api::docs::lookup(name).unwrap_or_else(|| panic!("`{name}` is not documented"));
        assert!(!usage.is_empty() && !doc.is_empty());
        let takes_a_field = |s: &String| s.starts_with(&format!("{name}(")) && s.contains("Field");
        assert!(sigs.iter().any(takes_a_field), "`{name}` takes no Field");
    }
    assert!(matdem_rs::api::docs::lookup("min").unwrap().0.contains("min(a, b)"));
}

#[test]
fn sqrt_of_a_negative_element_is_refused_naming_the_index() {
    let e = refusal("sqrt_neg", "field([4.0, 1.0, -3.2e-4]).sqrt()");
    assert!(e.contains("sqrt: element 2 is -3.2e-4 (negative)"), "{e}");
    assert!(e.contains("abs(f)"), "says what to do: {e}");
}

#[test]
fn division_by_zero_is_refused_naming_the_element() {
    let e = refusal("div_ff", "field([1.0, 2.0, 3.0]) / field([1.0, 0.0, 1.0])");
    assert!(e.contains("`/`: element 1 divides 2 by zero"), "{e}");
    assert!(e.contains("a.select(m) / b.select(m)"), "says what to do: {e}");
    let e = refusal("div_fn", "field([1.0, 2.0]) / 0");
    assert!(e.contains("`/`: element 0 divides 1 by zero"), "{e}");
    let e = refusal("div_nf", "1.0 / field([4.0, 0.0])");
    assert!(e.contains("`/`: element 1 divides 1 by zero"), "{e}");
    let e = refusal("zero_zero", "field([0.0]) / field([0.0])");
    assert!(e.contains("element 0 divides 0 by zero"), "{e}");
}

#[test]
fn ln_and_log10_of_a_non_positive_element_are_refused_naming_it() {
    let e = refusal("ln_zero", "field([1.0, 0.0]).ln()");
    assert!(e.contains("ln: element 1 is 0"), "{e}");
    let e = refusal("log10_neg", "field([-2.0]).log10()");
    assert!(e.contains("log10: element 0 is -2 (negative)"), "{e}");
    assert!(e.contains("f.select(f > 0.0)"), "says what to do: {e}");
}

#[test]
fn overflow_and_powers_without_a_real_value_are_refused_naming_the_element() {
    let e = refusal("exp_big", "field([1.0, 800.0]).exp()");
    assert!(e.contains("exp: element 1 is 800"), "{e}");
    let e = refusal("mul_big", "field([1e300]) * field([1e300])");
    assert!(e.contains("`*`: element 0 overflows"), "{e}");
    let e = refusal("pow_neg", "field([4.0, -8.0]).pow(0.5)");
    assert!(e.contains("pow: element 1 is -8 (negative) and the exponent 0.5 is not a whole number"), "{e}");
    let e = refusal("pow_zero", "field([0.0]) ** -1");
    assert!(e.contains("`**`: element 0 is 0 and 0^-1 divides by zero"), "{e}");
    assert_eq!(values("pow_odd", "field([-8.0]).pow(3)"), [-512.0]);
}

#[test]
fn a_nan_or_infinite_number_operand_is_refused() {
    let e = refusal("nan_scalar", "field([1.0]) * (0.0 / 0.0)");
    assert!(e.contains("`*`: the number NaN is not finite"), "{e}");
    let e = refusal("inf_where", "where(field([1.0]) > 0.0, 1.0 / 0.0, 0.0)");
    assert!(e.contains("where: the number inf is not finite"), "{e}");
}

#[test]
fn mean_min_and_max_of_an_empty_selection_are_refused_naming_size_0() {
    for what in ["mean", "min", "max"] {
        let e = refusal("empty", &format!("let f = field([1.0, 2.0]); f.select(f > 5.0).{what}()"));
        assert!(e.contains(&format!("{what} of an empty field (0 values)")), "{e}");
    }
    let (engine, _, _) = engine("empty_sum");
    assert_eq!(engine.eval::<f64>("field([]).sum()").unwrap(), 0.0, "an empty sum is 0");
}

#[test]
fn reductions_refuse_a_missing_value_naming_it_and_is_finite_selects_the_rest() {
    let script = r#"let t = new_table(); t.add_row(#{ a: 1.0 }); t.add_row(#{ a: 3.0, b: 5.0 }); t.add_row(#{ a: 2.0, b: 7.0 });"#;
    let e = refusal("nan_mean", &format!("{script} t[\"b\"].mean()"));
    assert!(e.contains("mean: element 0 is NaN"), "{e}");
    assert!(e.contains("f.select(f.is_finite()).mean()"), "says what to do: {e}");
    let e = refusal("nan_max", &format!("{script} t[\"b\"].max()"));
    assert!(e.contains("max: element 0 is NaN"), "{e}");
    let (engine, _, _) = engine("nan_select");
    let mean: f64 = engine.eval(&format!("{script} let b = t[\"b\"]; b.select(b.is_finite()).mean()")).unwrap();
    assert_eq!(mean, 6.0);
    // A missing value stays missing through element-wise maths, unrefused.
    let v = values("nan_through", &format!("{script} t[\"b\"] * 2.0 + 1.0"));
    assert!(v[0].is_nan() && v[1] == 11.0, "{v:?}");
}

#[test]
fn an_inverted_or_empty_porosity_window_is_refused_naming_the_axis() {
    let e = refusal("porosity_inv", &format!("{SMALL_BOX} d.porosity_box([0.0, 0.003, 0.0], [0.003, 0.0, 0.002])"));
    assert!(e.contains("porosity_box: the window is empty or inverted along y"), "{e}");
    let e = refusal("porosity_flat", &format!("{SMALL_BOX} d.porosity_box([0.0, 0.0, 0.001], [0.003, 0.003, 0.001])"));
    assert!(e.contains("along z"), "{e}");
    let e = refusal("porosity_cyl", &format!("{SMALL_BOX} d.porosity_cylinder(0.001, 0.002, 0.0)"));
    assert!(e.contains("porosity_cylinder: the window must have a radius > 0 and z0 < z1"), "{e}");
    let (engine, _, _) = engine("porosity_ok");
    let n: f64 = engine.eval(&format!("{SMALL_BOX} d.porosity_box([0.0, 0.0, 0.0], [0.003, 0.003, 0.002])")).unwrap();
    assert!(n > 0.0 && n < 1.0, "{n}");
}

#[test]
fn a_chart_with_a_nan_point_warns_once_naming_the_series_and_index() {
    let (engine, host, dir) = engine("chart_gap");
    engine
        .run(
            r#"let c = chart("t", "x", "y").series("gappy", field([0.0, 1.0, 2.0, 3.0]), field([0.0, 1.0, 0.0 / 0.0, 9.0]));
               c.save("c"); c.save("c");"#,
        )
        .unwrap();
    let warnings = host.warnings.borrow();
    assert_eq!(warnings.len(), 1, "once, not per save: {warnings:?}");
    let w = &warnings[0].1;
    assert!(w.contains("chart `c`: series `gappy` has 1 point(s)") && w.contains("index 2 (x = 2, y = NaN)"), "{w}");
    assert!(dir.join("c.svg").is_file(), "the chart is still drawn");
}

#[test]
fn a_column_name_with_comma_and_newline_round_trips_through_csv() {
    let (engine, _, dir) = engine("csv_quote");
    let script = format!(
        r#"{SMALL_BOX}
        d.record(#{{ "a,b\nc": 1.5 }});
        d.status.save("status.csv");
        let t = new_table(); t.add_row(#{{ "a,b\nc": 2.0, "q\"x": 3.0 }}); t.save("t.csv");
        "#
    );
    engine.run(&script).unwrap();
    let t = std::fs::read_to_string(dir.join("t.csv")).unwrap();
    assert_eq!(t, "\"a,b\nc\",\"q\"\"x\"\n2,3\n");
    let status = std::fs::read_to_string(dir.join("status.csv")).unwrap();
    let mut reader = csv::Reader::from_reader(status.as_bytes());
    let header = reader.headers().unwrap().clone();
    let k = header.iter().position(|h| h == "a,b\nc").unwrap_or_else(|| panic!("header {header:?}"));
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 1);
    assert_eq!(&rows[0][k], "1.5");
    assert_eq!(rows[0].len(), header.len());
}

#[test]
fn load_table_reads_quoted_cells_from_a_spreadsheet_export() {
    let dir = crate::common::temp_dir("csv_load");
    std::fs::write(dir.join("data.csv"), "\"depth, m\",\"say \"\"hi\"\"\"\n1.5,2\n").unwrap();
    let script = r#"let t = load_table("data.csv"); print(t["depth, m"][0] + t["say \"hi\""][0]);"#;
    let o = crate::common::run_script(&dir, "load.rhai", script, &["--backend", "cpu"]);
    assert!(o.status.success(), "{}", crate::common::stderr(&o));
    assert_eq!(crate::common::stdout(&o).trim(), "3.5");
}

#[test]
fn the_critical_step_of_a_model_without_particles_is_refused_not_nan() {
    let e = refusal("critical_empty", &format!("{SMALL_BOX} d.remove(\"all\"); d.critical_dt()"));
    assert!(e.contains("critical_dt: the model has no particles"), "{e}");
}

/// Sample mean and variance.
fn moments(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    (mean, v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0))
}

#[test]
fn random_fields_have_their_distributions_moments_and_repeat_with_their_seed() {
    // 100,000 draws: the mean's standard error is σ/316; each mean is held to 5 of them and
    // each variance to 3 % (its own relative standard error, √((κ − 1)/n) with κ the kurtosis, is
    // 0.3–0.9 % for these laws).
    let n = 100_000;
    let check = |name: &str, script: &str, mean: f64, var: f64| {
        let v = values(name, script);
        assert_eq!(v.len(), n);
        let (m, s2) = moments(&v);
        assert!((m - mean).abs() < 5.0 * (var / n as f64).sqrt(), "{script}: mean {m}, expected {mean}");
        assert!((s2 / var - 1.0).abs() < 0.03, "{script}: variance {s2}, expected {var}");
        v
    };
    let u = check("rf_uniform", "random_field(100000, 1)", 0.5, 1.0 / 12.0);
    assert!(u.iter().all(|x| (0.0..1.0).contains(x)));
    check("rf_normal", "random_field(100000, 2, \"normal\")", 0.0, 1.0);
    // Weibull of shape 2 and scale 1: mean Γ(3/2) = √π/2, variance Γ(2) − Γ(3/2)² = 1 − π/4.
    let pi = std::f64::consts::PI;
    let w = check("rf_weibull", "random_field(100000, 3, \"weibull\", 2)", pi.sqrt() / 2.0, 1.0 - pi / 4.0);
    assert!(w.iter().all(|x| *x > 0.0));
    // Shape 1 is the exponential law: mean 1, variance 1.
    check("rf_exponential", "random_field(100000, 4, \"weibull\", 1.0)", 1.0, 1.0);
    // The same seed gives the same values, another seed others.
    assert_eq!(values("rf_again", "random_field(5, 7)"), values("rf_again2", "random_field(5, 7)"));
    assert_ne!(values("rf_other", "random_field(5, 7)"), values("rf_other2", "random_field(5, 8)"));
}

#[test]
fn random_fields_refuse_bad_shapes_seeds_sizes_and_names() {
    for (script, says) in [
        ("random_field(3, 1, \"weibull\", 0.0)", "the shape m must be a number above 0"),
        ("random_field(3, 1, \"weibull\")", "give its shape m"),
        ("random_field(3, 1, \"normal\", 2.0)", "this distribution takes no shape"),
        ("random_field(3, 1, \"gauss\")", "unknown distribution; use \"uniform\", \"normal\" or \"weibull\""),
        ("random_field(3, -1)", "the seed must be 0 or more"),
        ("random_field(-3, 1)", "a field holds 0 to"),
    ] {
        let e = refusal("rf_bad", script);
        assert!(e.contains(says), "{script}: {e}");
    }
}
