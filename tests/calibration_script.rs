//! Paper 002's calibration toolkit from a script: an orthogonal design, its ANOVA with
//! pooling and charts, single-factor regressions, the response-surface inversion, generic
//! least squares on a script function and the shear-test Mohr–Coulomb fit.

use matdem_rs::api::Host;
use std::rc::Rc;

fn engine(dir: &std::path::Path) -> rhai::Engine {
    matdem_rs::new_engine(Rc::new(Host::new(dir.to_path_buf())))
}

/// A synthetic material over an L25: τ rises with λ and μ, φ′ with μ, C with λ and σc.
const DESIGN: &str = r#"
let d = orthogonal_design(["lambda", "mu", "sigma_c", "c_bar", "phi_bar", "E"],
    [[0.5, 0.75, 1.0, 1.25, 1.5], [0.2, 0.4, 0.6, 0.8, 1.0], [2e5, 4e5, 6e5, 8e5, 1e6],
     [1e5, 2e5, 3e5, 4e5, 5e5], [10.0, 20.0, 30.0, 40.0, 50.0], [1e8, 2e8, 3e8, 4e8, 5e8]]);
fn synthetic(p) {
    #{ tau: 40.0 + 30.0 * p.lambda + 8.0 * p.lambda * p.lambda + 20.0 * p.mu + 1.5e-5 * p.sigma_c + 1e-9 * p.E
           + 2e-6 * p.c_bar + 0.002 * p.phi_bar,
       phi: 12.0 + 25.0 * p.mu - 6.0 * p.mu * p.mu + 0.5 * p.lambda + 0.01 * p.phi_bar,
       C: -20.0 + 30.0 * p.lambda + 4e-5 * p.sigma_c - 2e-11 * p.sigma_c * p.sigma_c + 1e-6 * p.c_bar }
}
let tau = []; let phi = []; let C = [];
for p in d.points() { let r = synthetic(p); tau.push(r.tau); phi.push(r.phi); C.push(r.C); }
"#;

#[test]
fn an_l25_design_its_anova_with_pooling_and_the_charts() {
    let dir = crate::common::temp_dir("calibration_anova");
    let e = engine(&dir);
    let script = format!(
        r#"{DESIGN}
        let refused = "";
        try {{ anova(d, tau); }} catch (err) {{ refused = `${{err}}`; }}
        let a = anova(d, tau, #{{ pool: 2, name: "tau" }});
        a.save("anova_tau.csv");
        a.plot_effects("effects_tau");
        a.plot_f("f_tau");
        d.save("design.csv");
        #{{ name: d.name, runs: d.runs, orthogonal: d.orthogonal, refused: refused, rows: a.rows,
           dof_error: a.dof_error, ranking: a.ranking, significant: a.significant(0.01),
           lambda_levels: d.level("lambda"), first: d.point(0) }}"#
    );
    let out: rhai::Map = e.eval(&script).unwrap_or_else(|err| panic!("{err}"));
    assert_eq!(out["name"].to_string(), "L25(5^6)");
    assert_eq!(out["runs"].as_int().unwrap(), 25);
    assert!(out["orthogonal"].as_bool().unwrap());
    let refused = out["refused"].to_string();
    assert!(refused.contains("no degrees of freedom") && refused.contains("pool"), "{refused}");
    assert_eq!(out["dof_error"].as_int().unwrap(), 8);
    let ranking = out["ranking"].to_string();
    assert!(ranking.starts_with("[\"lambda\", \"mu\", \"sigma_c\""), "{ranking}");
    // λ's effect: level means of 30λ + 8λ² over its levels, the rest averaging out.
    let rows = out["rows"].clone().into_array().unwrap();
    let lambda = rows[0].clone().cast::<rhai::Map>();
    let lv = [0.5f64, 0.75, 1.0, 1.25, 1.5].map(|l| 30.0 * l + 8.0 * l * l);
    let mean = lv.iter().sum::<f64>() / 5.0;
    let ss = 5.0 * lv.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    assert!((lambda["ss"].as_float().unwrap() - ss).abs() < 1e-9 * ss, "{lambda:?}");
    assert!(lambda["p"].as_float().unwrap() < 0.01 && lambda["significance"].to_string() == "**");
    for f in ["anova_tau.csv", "effects_tau.svg", "effects_tau.png", "f_tau.svg", "f_tau.png", "design.csv"] {
        assert!(dir.join(f).is_file(), "{f} not written");
    }
    let csv = std::fs::read_to_string(dir.join("anova_tau.csv")).unwrap();
    assert!(csv.starts_with("source,ss,dof,ms,f,p") && csv.contains("(pooled)") && csv.contains("\nerror,"), "{csv}");
    let svg = std::fs::read_to_string(dir.join("f_tau.svg")).unwrap();
    assert!(svg.contains("F0.05(4, 8)") && svg.contains("F0.01(4, 8)"));
}

#[test]
fn regressions_and_the_inversion_recover_known_answers() {
    let dir = crate::common::temp_dir("calibration_inversion");
    let e = engine(&dir);
    let script = format!(
        r#"{DESIGN}
        let x = [0.5, 0.625, 0.75, 0.875, 1.0, 1.125, 1.25, 1.375, 1.5];
        let y = x.map(|v| 50.837 * (0.6 * v).exp());
        let r = regress(x, y);
        r.plot("tau_lambda", "τc against λ", "λ", "τc [kPa]");
        let lg = regress(x, x.map(|v| 9.8722 * v.ln() + 12.85));
        let s = response_surface(d, #{{ tau: tau, phi: phi, C: C }});
        let truth = #{{ lambda: 1.1, mu: 0.55, sigma_c: 7.3e5, c_bar: 3e5, phi_bar: 30.0, E: 3e8 }};
        let t = synthetic(truth);
        let inv = s.invert(#{{ tau: t.tau, phi: t.phi, C: t.C }}, #{{ c_bar: 3e5, phi_bar: 30.0, E: 3e8 }});
        let fit = least_squares(|p| [p[0] - 3.0, 10.0 * (p[1] - p[0] * p[0])], [0.0, 0.0], #{{}});
        let mc = shear_envelope([50e3, 100e3, 200e3], [50e3 * 0.6 + 5e3, 100e3 * 0.6 + 5e3, 200e3 * 0.6 + 5e3]);
        #{{ form: r.form, a: r.a, b: r.b, r2: r.r2, log_form: lg.form, log_a: lg.a, back: r.invert(r.predict(0.8)),
           inv: inv, r2s: s.r2, ls: fit.x, c: mc.c, phi: mc.phi }}"#
    );
    let out: rhai::Map = e.eval(&script).unwrap_or_else(|err| panic!("{err}"));
    let f = |k: &str| out[k].as_float().unwrap();
    assert_eq!(out["form"].to_string(), "exponential");
    assert!((f("a") - 50.837).abs() < 1e-8 && (f("b") - 0.6).abs() < 1e-10 && (f("r2") - 1.0).abs() < 1e-12);
    assert_eq!(out["log_form"].to_string(), "logarithmic");
    assert!((f("log_a") - 9.8722).abs() < 1e-10);
    assert!((f("back") - 0.8).abs() < 1e-12);
    let inv = out["inv"].clone().cast::<rhai::Map>();
    let point = inv["point"].clone().cast::<rhai::Map>();
    for (k, want) in [("lambda", 1.1), ("mu", 0.55), ("sigma_c", 7.3e5)] {
        let got = point[k].as_float().unwrap();
        assert!((got - want).abs() < 1e-6 * want, "{k}: {got} vs {want}");
    }
    let r2s = out["r2s"].clone().cast::<rhai::Map>();
    assert!(r2s.values().all(|r| (r.as_float().unwrap() - 1.0).abs() < 1e-10), "{r2s:?}");
    let ls: Vec<f64> = out["ls"].clone().into_array().unwrap().iter().map(|v| v.as_float().unwrap()).collect();
    assert!((ls[0] - 3.0).abs() < 1e-8 && (ls[1] - 9.0).abs() < 1e-7, "{ls:?}");
    assert!((f("c") - 5e3).abs() < 1e-6 && (f("phi") - 0.6f64.atan().to_degrees()).abs() < 1e-10);
    assert!(dir.join("tau_lambda.svg").is_file() && dir.join("tau_lambda.png").is_file());
}

#[test]
fn a_refinement_from_a_script_meets_targets_the_plain_inversion_misses() {
    // The "runs" differ from the synthetic material the surface holds by products of factors
    // (which a surface without interactions cannot fit): propose, run, confirm until within.
    let dir = crate::common::temp_dir("calibration_refinement");
    let e = engine(&dir);
    let script = format!(
        r#"{DESIGN}
        fn run(p) {{
            let r = synthetic(p);
            #{{ tau: r.tau + 12.0 * p.lambda * p.mu, phi: r.phi + 3.0 * p.mu * p.lambda, C: r.C + 4e-5 * p.lambda * p.sigma_c }}
        }}
        let s = response_surface(d, #{{ tau: tau, phi: phi, C: C }});
        let truth = #{{ lambda: 1.1, mu: 0.55, sigma_c: 7.3e5, c_bar: 3e5, phi_bar: 30.0, E: 3e8 }};
        let t = run(truth);
        let r = s.refinement(#{{ tau: t.tau, phi: t.phi, C: t.C }}, #{{ c_bar: 3e5, phi_bar: 30.0, E: 3e8 }});
        let worst = [];
        let last = #{{}};
        for round in 1..=8 {{
            let inv = r.propose();
            let errs = r.confirm(inv.point, run(inv.point));
            worst.push(errs.values().reduce(|a, e| max(a, e.abs()), 0.0));
            last = inv.point;
            if r.within(1e-9) {{ break; }}
        }}
        let refused = "";
        try {{ r.confirm(last, #{{ tau: 1.0 }}); }} catch (err) {{ refused = `${{err}}`; }}
        #{{ worst: worst, last: last, met: r.within(1e-9), text: `${{r}}`, refused: refused }}"#
    );
    let out: rhai::Map = e.eval(&script).unwrap_or_else(|err| panic!("{err}"));
    let worst: Vec<f64> = out["worst"].clone().into_array().unwrap().iter().map(|v| v.as_float().unwrap()).collect();
    assert!(worst[0] > 0.01, "the plain inversion meets the targets already: {worst:?}");
    assert!(out["met"].as_bool().unwrap() && worst.len() <= 8, "{worst:?}");
    let last = out["last"].clone().cast::<rhai::Map>();
    for (k, want) in [("lambda", 1.1), ("mu", 0.55), ("sigma_c", 7.3e5)] {
        let got = last[k].as_float().unwrap();
        assert!((got - want).abs() < 1e-6 * want, "{k}: {got} vs {want} ({worst:?})");
    }
    assert!(out["text"].to_string().contains("by ") && out["text"].to_string().contains("confirmation run(s)"));
    let refused = out["refused"].to_string();
    assert!(refused.contains("`C` is missing") && refused.contains("C, phi, tau"), "{refused}");
}

#[test]
fn bad_calibration_input_is_refused_with_what_to_do() {
    let dir = crate::common::temp_dir("calibration_bad");
    let e = engine(&dir);
    for (script, needle) in [
        ("orthogonal_array(18, 3)", "L9 and L27"),
        ("orthogonal_array(36, 6)", "prime power"),
        ("orthogonal_design([\"a\", \"b\"], [[1.0, 2.0, 3.0], [1.0, 2.0]])", "same number of levels"),
        ("anova(orthogonal_array(9, 3), [1.0, 2.0])", "2 responses for the 9 runs"),
        (
            "anova(orthogonal_array(9, 3), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], #{ pool: [\"zz\"] })",
            "cannot pool `zz`",
        ),
        ("regress([1.0, 2.0, 3.0], [1.0, 2.0, 3.0], \"cubic\")", "unknown regression form `cubic`"),
        ("regress([-1.0, 1.0, 2.0], [1.0, 2.0, 3.0], \"power\")", "every x > 0"),
        ("shear_envelope([1e5, 1e5], [5e4, 6e4])", "all equal"),
        ("least_squares(|p| [p[0]], [1.0], #{ lower: [0.0, 1.0] })", "bound(s)"),
        ("least_squares(|p| throw \"run failed\", [1.0], #{})", "run failed"),
        ("orthogonal_array(9, 3).point(9)", "runs are 0 … 8"),
    ] {
        let err = e.eval::<rhai::Dynamic>(script).expect_err(script).to_string();
        assert!(err.contains(needle), "{script}: {err}");
    }
}
