//! Materials say what they are: every value that was derived or left at a default is shown
//! by `print(m)` with where it came from, and an ambiguous Hertz definition is refused.

use crate::common::*;

fn run(name: &str, script: &str) -> std::process::Output {
    let dir = temp_dir(name);
    run_script(&dir, "m.rhai", script, &[])
}

#[test]
fn micro_material_from_kn_reports_derived_young_and_default_poisson() {
    let o = run("prov_kn", r#"let m = material_micro("s", #{ kn: 1e6, r: 1e-3, mu_p: 0.3 }); print(m);"#);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("young: derived: E = Kn/(πR) at R = 1.0000e-3 m"), "{out}");
    assert!(out.contains("poisson: default: 0"), "{out}");
    assert!(out.contains("ks: default: 0, no shear spring"), "{out}");
    assert!(out.contains("density: default: 2650"), "{out}");
    assert!(!out.contains("mu_p:") && !out.contains("kn:"), "given values are not annotated: {out}");
}

#[test]
fn hertz_micro_material_takes_young_and_poisson_and_derives_kn_from_them() {
    let o = run(
        "prov_hertz",
        r#"let m = material_micro("h", #{ young: 7e10, poisson: 0.25, r: 2e-3, mu_p: 0.5, density: 2500 });
           print(m.young); print(m.poisson); print(m.kn); print(m);"#,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[0].parse::<f64>().unwrap(), 7e10);
    assert_eq!(lines[1].parse::<f64>().unwrap(), 0.25);
    let kn: f64 = lines[2].parse().unwrap();
    let expected = std::f64::consts::PI * 7e10 * 2e-3;
    assert!((kn / expected - 1.0).abs() < 1e-12, "Kn = πER: {kn} vs {expected}");
    assert!(out.contains("kn: derived: Kn = π·E·R at R = 2.0000e-3 m"), "{out}");
    assert!(!out.contains("young:") && !out.contains("poisson:"), "E and ν were given: {out}");
}

#[test]
fn ambiguous_hertz_definitions_are_refused_with_what_to_give() {
    for (script, says) in [
        (r#"material_micro("a", #{ kn: 1e6, young: 1e9 })"#, "`young` without `poisson`"),
        (r#"material_micro("b", #{ kn: 1e6, poisson: 0.2 })"#, "`poisson` without `young`"),
        (r#"material_micro("c", #{ mu_p: 0.3 })"#, "missing `kn`"),
        (r#"material_micro("d", #{ kn: 1e6 })"#, "give `young` and `poisson`, or `r`"),
    ] {
        let o = run("prov_refuse", script);
        assert_eq!(o.status.code(), Some(1), "{script} must be refused");
        assert!(stderr(&o).contains(says), "{script}: {}", stderr(&o));
    }
}

#[test]
fn macro_material_reports_its_micro_values_as_derived_by_the_lattice_formulas() {
    let o = run(
        "prov_macro",
        r#"let m = material("rock", #{ E: 20e9, nu: 0.2, Tu: 5e6, Cu: 50e6, mu_i: 0.6, d: 1e-3 });
           print(m); m.kn = 1e6; print("--"); print(m);"#,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let (before, after) = out.split_once("--").unwrap();
    assert!(before.contains("kn: derived: lattice formulas (paper 003, app. A)"), "{before}");
    assert!(before.contains("mu_p: derived: lattice formulas"), "{before}");
    assert!(!after.contains("kn: derived"), "an assigned Kn is given: {after}");
    assert!(after.contains("ks: derived"), "{after}");
}
