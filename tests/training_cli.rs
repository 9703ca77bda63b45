//! Material training through scripts: refused targets, the files a training writes, and a
//! later script loading (and rescaling) the trained material with one call; the stdlib
//! material tests write their charts.

use crate::common::*;

#[test]
fn train_refuses_invalid_targets_and_says_what_to_do() {
    let cases = [
        ("nu: 0.25", "ν ≤ 0.2"),
        ("mu_i: 0.3", "μi ≥ 0.354"),
        ("Tu: -5.0", "strengths must be finite numbers > 0"),
        ("Cu: 0.0", "strengths must be finite numbers > 0"),
    ];
    for (k, (spoil, hint)) in cases.iter().enumerate() {
        let dir = temp_dir(&format!("train_refuses_{k}"));
        let mut targets = vec!["E: 5e7", "nu: 0.15", "Tu: 2e4", "Cu: 2e5", "mu_i: 0.6"];
        let key = spoil.split(':').next().unwrap();
        targets.retain(|t| !t.starts_with(&format!("{key}:")));
        targets.push(spoil);
        let script = format!("train(#{{ name: \"x\", {} }}, #{{}});\n", targets.join(", "));
        let o = run_script(&dir, "s.rhai", &script, &[]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(hint) && err.contains("train(\"x\")"), "{spoil}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // An unknown option is named with the known ones.
    let dir = temp_dir("train_refuses_option");
    let o = run_script(
        &dir,
        "s.rhai",
        "train(#{ E: 5e7, nu: 0.15, Tu: 2e4, Cu: 2e5, mu_i: 0.6 }, #{ element: 100 });\n",
        &[],
    );
    assert!(stderr(&o).contains("did you mean `elements`"), "{}", stderr(&o));
}

#[test]
fn one_round_of_training_writes_its_report_and_load_material_reads_it_back() {
    let dir = temp_dir("train_one_round");
    let script = r#"
        let r = train(#{ name: "soil", E: 5e7, nu: 0.15, Tu: 2e4, Cu: 2e5, mu_i: 0.6 },
                      #{ elements: 120, rounds: 1, steps_to_peak: 2000, quiet: true });
        let m = load_material("soil");
        if m.kn != r.micro.kn { throw "loaded Kn differs"; }
        let m4 = load_material("soil", 2.0 * r.d);
        if (m4.kn / m.kn - 2.0).abs() > 1e-9 { throw `rescaled Kn ratio ${m4.kn / m.kn}`; }
        if (m4.fs0 / m.fs0 - 4.0).abs() > 1e-9 { throw "Fs0 must scale with d²"; }
        if r.rounds.rows != 1 { throw "one round expected"; }
        print(`E ${r.measured.E}`);
    "#;
    let o = run_script(&dir, "s.rhai", script, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.join("out");
    for f in [
        "train_soil/rounds.csv",
        "train_soil/E.svg",
        "train_soil/nu.png",
        "train_soil/Tu.svg",
        "train_soil/Cu.svg",
        "train_soil/mu_i.svg",
        "train_soil/stress_strain.png",
        "materials/soil.ron",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let csv = std::fs::read_to_string(out.join("train_soil/rounds.csv")).unwrap();
    assert!(csv.starts_with("round,E,nu,Tu,Cu,mu_i,"), "{csv}");
    let ron = std::fs::read_to_string(out.join("materials/soil.ron")).unwrap();
    assert!(ron.contains("diameter") && ron.contains("converged"), "{ron}");
    // A missing material says where it looked and what to do.
    let o = run_script(&dir, "t.rhai", "load_material(\"basalt\");\n", &[]);
    assert!(stderr(&o).contains("no trained material `basalt`") && stderr(&o).contains("train it first"));
}

#[test]
fn stdlib_material_tests_return_values_and_write_charts() {
    let dir = temp_dir("stdlib_material_tests");
    let script = r#"
        let m = material("soil", #{ E: 5e7, nu: 0.15, Tu: 2e4, Cu: 2e5, mu_i: 0.6, d: 2e-3 });
        let s = test_sample(m, #{ elements: 120 });
        let u = uniaxial_compression(s, #{ steps_to_peak: 2000 });
        let t = uniaxial_tension(s, #{ steps_to_peak: 2000 });
        let c = confined_compression(s, [2e4, 4e4], #{ steps_to_peak: 2000 });
        if !(u.E > 0.0 && u.Cu > 0.0 && t.Tu > 0.0) { throw "values must be positive"; }
        if !(t.Tu < u.Cu) { throw "tension must be weaker than compression"; }
        if c.sigma1.len() != 3 || !(c.sigma1[2] > c.sigma1[0]) { throw "confinement must strengthen"; }
        print(`E ${u.E} nu ${u.nu} Cu ${u.Cu} Tu ${t.Tu} mu_i ${c.mu_i}`);
    "#;
    let o = run_script(&dir, "s.rhai", script, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["uniaxial_compression.svg", "uniaxial_tension.png", "confined_compression.svg"] {
        assert!(dir.join("out").join(f).is_file(), "missing {f}");
    }
}
