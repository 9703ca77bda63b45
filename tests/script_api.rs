//! The script API from Rhai, in process: builder, balance, groups, whole arrays, masks,
//! tables, charts and pictures.

use crate::common::SMALL_BOX;
use matdem_rs::api::Host;
use std::rc::Rc;

fn eval<T: Clone + 'static>(name: &str, script: &str) -> T {
    let dir = crate::common::temp_dir(name);
    let host = Rc::new(Host::new(dir));
    let engine = matdem_rs::new_engine(host);
    engine.eval::<T>(script).unwrap_or_else(|e| panic!("script failed: {e}"))
}

#[test]
fn box_builder_fills_container_with_groups_and_walls() {
    let n: i64 = eval("builder", &format!("{SMALL_BOX} d.n"));
    assert!(n > 20, "{n} particles");
    let walls: rhai::Array = eval("builder_walls", &format!("{SMALL_BOX} d.boundaries"));
    let names: Vec<String> = walls.into_iter().map(|w| w.to_string()).collect();
    assert_eq!(names, ["bottom", "left", "right", "front", "back", "top_platen"]);
    let inside: bool = eval(
        "builder_inside",
        &format!("{SMALL_BOX} (d.x - d.r).min() >= 0.0 && (d.x + d.r).max() <= 0.004 && (d.z - d.r).min() >= 0.0"),
    );
    assert!(inside);
}

#[test]
fn field_arithmetic_masks_and_reductions_run_natively() {
    let v: f64 =
        eval("fields", "let a = field([1.0, 2.0, 3.0, 4.0]); let m = a > 2.0; (a * 2.0 + 1.0).select(m).sum()");
    assert_eq!(v, 7.0 + 9.0);
    let c: i64 = eval("masks", "let a = field([1.0, 2.0, 3.0, 4.0]); ((a > 1.5) & !(a > 3.5)).count()");
    assert_eq!(c, 2);
    let mean: f64 = eval("mean", "(field([1, 2, 3]) - 1).mean()");
    assert_eq!(mean, 1.0);
}

#[test]
fn groups_from_masks_fix_and_balance_settle_the_sample() {
    let script = format!(
        r#"{SMALL_BOX}
        d.gravity = [0.0, 0.0, -9.81];
        let low = d.z < 0.001;
        d.group_where("low", low);
        d.fix("low", "xyz");
        let z0 = d.z;
        d.balance(3000);
        let moved = (d.z - z0).abs().select(d.in_group("low")).max();
        [d.group("low").len(), moved, d.step]
    "#
    );
    let r: rhai::Array = eval("groups", &script);
    assert!(r[0].as_int().unwrap() > 0);
    assert_eq!(r[1].as_float().unwrap(), 0.0, "fixed particles must not move");
    assert_eq!(r[2].as_int().unwrap(), 3000);
}

#[test]
fn records_make_a_table_saved_as_csv_and_a_chart() {
    let dir = crate::common::temp_dir("records");
    let host = Rc::new(Host::new(dir.clone()));
    let engine = matdem_rs::new_engine(host);
    let script = format!(
        r#"{SMALL_BOX}
        d.gravity = [0.0, 0.0, -9.81];
        for i in 0..3 {{ d.run(200); d.record(#{{ stage: i }}); }}
        d.status.save("status.csv");
        plot(d.status, "time", "kinetic_energy").save("ke");
        d.show("z", "z.png");
        d.status.rows
    "#
    );
    let rows: i64 = engine.eval(&script).unwrap();
    assert_eq!(rows, 3);
    let csv = std::fs::read_to_string(dir.join("status.csv")).unwrap();
    assert!(csv.starts_with("step,time,kinetic_energy"), "{csv}");
    assert!(csv.lines().next().unwrap().contains("stage"));
    assert_eq!(csv.lines().count(), 4);
    for f in ["ke.svg", "ke.png", "z.png"] {
        assert!(dir.join(f).metadata().unwrap().len() > 100, "{f} written");
    }
}

#[test]
fn bad_values_are_refused_with_a_message() {
    let dir = crate::common::temp_dir("bad_values");
    let host = Rc::new(Host::new(dir));
    let engine = matdem_rs::new_engine(host);
    for (script, needle) in [
        ("let b = new_box(\"x\"); b.ball_r = -1.0;", "must be a finite number ≥ 0"),
        ("material_micro(\"m\", #{ kn: -1.0, r: 1e-3 })", "kn"),
        ("material_micro(\"m\", #{ kn: 1e6, r: 1e-3, restitution: 2.0 })", "restitution"),
        (&format!("{SMALL_BOX} d.damping = 1.5;"), "damping"),
        (&format!("{SMALL_BOX} d.fix(\"nope\", \"x\");"), "unknown group `nope`"),
        (&format!("{SMALL_BOX} d.add_group(\"g\", [100000]);"), "out of range"),
        (&format!("{SMALL_BOX} d.contact_law = \"hertzz\";"), "did you mean `hertz`"),
    ] {
        let e = engine.eval::<rhai::Dynamic>(script).expect_err(script).to_string();
        assert!(e.contains(needle), "{script}: {e}");
    }
}

// d.rolling_resistance: the plan lists the stage (and epsd's lanes); the map reads back; bad
// values are refused with what to do instead; () switches it off.
#[test]
fn rolling_resistance_is_set_read_and_refused_from_scripts() {
    let plan: String = eval(
        "rolling_plan",
        &format!("{SMALL_BOX} d.rolling_resistance = #{{ model: \"epsd\", mu_r: 0.1, damping: 0.3 }}; d.plan()"),
    );
    assert!(plan.contains("rolling_resistance → integrate"), "{plan}");
    assert!(plan.contains("rolling resistance(epsd, μ_r 0.1, k_r = k_t·R_eff², η_r 0.3)"), "{plan}");
    assert!(plan.contains("per row entry (rolling_spring, wall_rolling_spring)"), "{plan}");
    let model: String = eval(
        "rolling_read",
        &format!("{SMALL_BOX} d.rolling_resistance = #{{ model: \"cdt\", mu_r: 0.2 }}; d.rolling_resistance.model"),
    );
    assert_eq!(model, "cdt");
    let off: String = eval(
        "rolling_off",
        &format!(
            "{SMALL_BOX} d.rolling_resistance = #{{ model: \"cdt\", mu_r: 0.2 }}; d.rolling_resistance = (); d.plan()"
        ),
    );
    let not_simulated = off.split("not simulated: ").nth(1).unwrap_or_default();
    assert!(not_simulated.contains("rolling resistance"), "{off}");
    for (bad, advice) in [
        ("#{ model: \"cdt\", mu_r: -0.1 }", "mu_r: 0.1"),
        ("#{ model: \"cdt\" }", "missing `mu_r`"),
        ("#{ model: \"rolling\", mu_r: 0.1 }", "\"cdt\""),
        ("#{ model: \"cdt\", mu_r: 0.1, damping: 0.3 }", "model: \"epsd\""),
        ("#{ model: \"cdt\", mu: 0.1 }", "mu_r"),
    ] {
        let dir = crate::common::temp_dir("rolling_bad");
        let engine = matdem_rs::new_engine(Rc::new(Host::new(dir)));
        let e = engine.eval::<()>(&format!("{SMALL_BOX} d.rolling_resistance = {bad};")).unwrap_err().to_string();
        assert!(e.contains(advice), "{bad}: {e}");
    }
}
