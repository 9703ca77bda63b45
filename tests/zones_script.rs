//! Paper 001 from a script: the zoned builder (`new_zoned`), its report, scaled copies of a
//! model and the material scaling law, and the refusals of bad input.

use matdem_rs::api::Host;
use std::rc::Rc;

fn engine(name: &str) -> rhai::Engine {
    matdem_rs::new_engine(Rc::new(Host::new(crate::common::temp_dir(name))))
}

const SMALL_ZONED: &str = r#"
let z = new_zoned("cpt");
z.radius = [0.01, 0.02];
z.grain_d = [4e-3, 6e-3];
z.mix = [0.006];
z.height = 0.015;
z.material = material_micro("sand", #{ kn: 3.3e5, ks: 3.3e5, mu_p: 0.5, r: 2e-3 });
let d = z.build_initial_model();
"#;

#[test]
fn zoned_builder_makes_groups_walls_and_a_report() {
    let e = engine("zoned_script");
    let script = format!(
        r#"{SMALL_ZONED}
        let rep = z.zone_report();
        #{{ groups: d.groups, walls: d.boundaries, names: rep.map(|r| r.name), n: d.n,
           counted: rep.reduce(|s, r| s + r.count, 0), coordination: rep[0].coordination,
           mix: rep[1].porosity, regions: z.regions }}"#
    );
    let out: rhai::Map = e.eval(&script).unwrap_or_else(|err| panic!("{err}"));
    let names: Vec<String> = out["names"].clone().into_array().unwrap().iter().map(|v| v.to_string()).collect();
    assert_eq!(names, ["zone1", "mix12", "zone2"]);
    let groups = out["groups"].to_string();
    for g in ["zone1", "mix12", "zone2", "sample"] {
        assert!(groups.contains(g), "group {g} missing: {groups}");
    }
    let walls = out["walls"].to_string();
    assert!(walls.contains("ring") && walls.contains("bottom") && walls.contains("top_platen"), "{walls}");
    assert_eq!(out["n"].as_int().unwrap(), out["counted"].as_int().unwrap(), "every grain is in one region");
    assert!(out["coordination"].as_float().unwrap() > 3.0);
    let mix = out["mix"].as_float().unwrap();
    assert!(mix > 0.25 && mix < 0.45, "mixing layer porosity {mix}");
}

#[test]
fn scaled_copies_and_materials_follow_the_law() {
    let e = engine("scaled_script");
    let script = format!(
        r#"{SMALL_ZONED}
        let big = d.scaled(3.0);
        let geo = scale_model(d, 2);
        let m = material_micro("s", #{{ kn: 1e6, ks: 4e5, xb: 1e-6, fs0: 2.0, mu_p: 0.5, r: 1e-3 }});
        let m3 = m.scaled(3.0);
        let m2 = scaled_material(m, 2);
        #{{ n: d.n, n3: big.n, r: d.r.max(), r3: big.r.max(), kn: m3.kn, ks: m3.ks, xb: m3.xb, fs0: m3.fs0,
           young: m3.young, young0: m.young, kn2: m2.kn, g: geo.r.max(), groups3: big.groups }}"#
    );
    let out: rhai::Map = e.eval(&script).unwrap_or_else(|err| panic!("{err}"));
    let f = |k: &str| out[k].as_float().unwrap();
    assert_eq!(out["n"].as_int().unwrap(), out["n3"].as_int().unwrap());
    assert!((f("r3") / f("r") - 3.0).abs() < 1e-12 && (f("g") / f("r") - 2.0).abs() < 1e-12);
    assert!((f("kn") - 3e6).abs() < 1e-6 && (f("ks") - 1.2e6).abs() < 1e-6);
    assert!((f("xb") - 3e-6).abs() < 1e-18 && (f("fs0") - 18.0).abs() < 1e-12);
    assert_eq!(f("young"), f("young0"));
    assert!((f("kn2") - 2e6).abs() < 1e-6);
    assert!(out["groups3"].to_string().contains("mix12"));
}

#[test]
fn bad_zones_and_scales_are_refused_with_what_to_do() {
    let e = engine("zoned_bad");
    let base = r#"let z = new_zoned("x"); z.radius = [0.01, 0.02]; z.grain_d = [4e-3, 6e-3]; z.height = 0.015;"#;
    for (tail, needle) in [
        ("z.radius = [-0.01, 0.02]; z.build_initial_model();", "must be > 0"),
        ("z.radius = [0.02, 0.01]; z.build_initial_model();", "must increase outwards"),
        ("z.grain_d = [6e-3, 4e-3]; z.build_initial_model();", "must not shrink outwards"),
        ("z.mix = [0.016]; z.build_initial_model();", "narrow the mixing layers"),
        ("z.mix = [0.003]; z.build_initial_model();", "narrower than one coarse grain"),
        ("z.height = -1.0;", "finite number ≥ 0"),
        ("z.radius = [0.01, \"a\"];", "number"),
        ("z.grain_d = [4e-3]; z.build_initial_model();", "one grain diameter per zone"),
        ("z.mix_porosity = 0.95; z.build_initial_model();", "[0.2, 0.7)"),
        ("z.seed = -1;", "seed must be 0 or more"),
        ("z.d", "not built yet"),
        ("z.zone_report()", "not built yet"),
        ("scaled_material(material_micro(\"m\", #{ kn: 1e6, r: 1e-3 }), 0.0)", "finite number > 0"),
        ("material_micro(\"m\", #{ kn: 1e6, r: 1e-3 }).scaled(-2)", "finite number > 0"),
    ] {
        let script = format!("{base} {tail}");
        let err = e.eval::<rhai::Dynamic>(&script).expect_err(&script).to_string();
        assert!(err.contains(needle), "{tail}: {err}");
    }
    let nan = format!("{base} z.radius = [0.01, 0.0 / 0.0]; z.build_initial_model();");
    let err = e.eval::<rhai::Dynamic>(&nan).expect_err("NaN radius").to_string();
    assert!(err.contains("finite"), "{err}");
    let neg = format!("{SMALL_ZONED} d.scaled(-1.0)");
    let err = e.eval::<rhai::Dynamic>(&neg).expect_err("negative scale").to_string();
    assert!(err.contains("finite number > 0"), "{err}");
}

// The CPT cone from a script (docs/cpt.md): d.add_cone, pushed into the small zoned chamber by
// d.move_boundary; d.boundary reads qc and fs (positive and finite once it has gone in: the
// grains push the cone back) and d.record() has the cone's columns. A servo on the cone, an
// unknown key and a 90° half-angle are refused.
#[test]
fn a_cone_pushed_into_the_chamber_reads_qc_and_fs() {
    let e = engine("cone_script");
    let script = format!(
        r#"{SMALL_ZONED}
        d.set_standard_dt();
        let top = d.z.max() + d.r.max();
        d.add_cone(#{{ name: "cone", apex: [0.0, 0.0, top + 1e-3], axis: [0, 0, 1], angle: 60, radius: 2e-3, rod_length: 0.03 }});
        d.move_boundary("cone", [0.0, 0.0, -0.5]);
        d.run(to_int(0.008 / (0.5 * d.dt)));
        d.record();
        let b = d.boundary("cone");
        #{{ qc: b.qc, fs: b.fs, tip: b.tip_force, sleeve: b.sleeve_force, z: b.position[2], top: top,
           cols: d.status.columns }}"#
    );
    let out: rhai::Map = e.eval(&script).unwrap_or_else(|err| panic!("{err}"));
    let (qc, tip) = (out["qc"].as_float().unwrap(), out["tip"].as_float().unwrap());
    assert!(qc.is_finite() && qc > 0.0 && tip > 0.0, "qc {qc}, tip force {tip}");
    assert!((qc - tip / (std::f64::consts::PI * 4e-6)).abs() <= 1e-9 * qc);
    assert!(out["fs"].as_float().unwrap().is_finite());
    let (z, top) = (out["z"].as_float().unwrap(), out["top"].as_float().unwrap());
    assert!((z - (top + 1e-3 - 0.008)).abs() < 1e-3, "apex at {z}");
    let cols = out["cols"].to_string();
    assert!(cols.contains("cone_qc") && cols.contains("cone_fs"), "{cols}");

    for (bad, want) in [
        (
            r#"d.add_cone(#{ name: "c", apex: [0,0,0], radius: 1e-3, rod_length: 0.01 }); d.set_platen_stress("c", 1e5);"#,
            "move_boundary",
        ),
        (r#"d.add_cone(#{ name: "c", apex: [0,0,0], radius: 1e-3, rod: 0.01 });"#, "rod_length"),
        (r#"d.add_cone(#{ name: "c", apex: [0,0,0], angle: 180, radius: 1e-3, rod_length: 0.01 });"#, "half-angle"),
    ] {
        let script = format!("{SMALL_ZONED}\nd.set_standard_dt();\n{bad}");
        let err = e.eval::<rhai::Dynamic>(&script).expect_err(bad).to_string();
        assert!(err.contains(want), "{bad}: {err}");
    }
}
