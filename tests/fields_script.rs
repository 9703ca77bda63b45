//! Issue 15 from a script: `d.enable("heat")`, `d.temperature` as a writable whole-array field,
//! `d.thermal` per material and per group, fixed and heated groups, the field step settings,
//! thermal expansion of radii, the water table, `d.plan()` listing the field stages and their
//! lanes, records and snapshots carrying temperature, and the refusals of bad input; moisture
//! (`d.enable("moisture")`, `d.water`, evaporation, the tables, records, snapshots, pictures).

use crate::common::SMALL_BOX;
use matdem_rs::api::Host;
use std::rc::Rc;

fn engine(name: &str) -> rhai::Engine {
    matdem_rs::new_engine(Rc::new(Host::new(crate::common::temp_dir(name))))
}

fn refusal(name: &str, script: &str) -> String {
    match engine(name).eval::<rhai::Dynamic>(script) {
        Ok(v) => panic!("{name}: accepted ({v}) instead of refused"),
        Err(e) => e.to_string(),
    }
}

// Heat on: every element starts at the reference temperature; a uniform rise of 100 K with
// α = 1e-5 grows every radius by 1e-3 of itself after one field step; a fixed hot group stays
// at its temperature while heat flows out of it; the plan names the stage and its lanes; a
// record carries the mean and largest temperature.
#[test]
fn heat_from_a_script_conducts_expands_and_is_recorded() {
    let script = format!(
        r#"{SMALL_BOX}
        // Grown a tenth, so that the loose box's elements touch and conduct.
        d.r = d.r * 1.1;
        d.enable("heat");
        let t0 = d.temperature.mean();
        d.thermal("m", #{{ conductivity: 2.0, specific_heat: 800.0, expansion: 1e-5 }});
        let r0 = d.r;
        d.temperature = d.reference_temperature + 100.0;
        d.run(1);
        let growth = (d.r / r0).mean();
        let g = d.conductance.max();
        d.add_group("hot", d.z < 0.001);
        d.fix_temperature("hot", 500.0);
        d.heat_every = 10;
        d.heat_substeps = 2;
        d.run(200);
        d.record();
        let plan = d.plan();
        let t = d.temperature;
        #{{ t0: t0, growth: growth, hot: t.select(d.in_group("hot")).min(), rest: t.select(!d.in_group("hot")).max(),
            plan: plan, mean: d.status["mean_temperature"][0], max: d.status["max_temperature"][0],
            every: d.heat_every, g: g }}"#
    );
    let out: rhai::Map = engine("heat_script").eval(&script).unwrap_or_else(|e| panic!("{e}"));
    let f = |k: &str| out[k].as_float().unwrap();
    assert!((f("t0") - 293.15).abs() < 1e-9, "{}", f("t0"));
    assert!((f("growth") - (1.0 + 1e-5 * 100.0)).abs() < 1e-12, "growth {}", f("growth"));
    assert_eq!(f("hot"), 500.0);
    let rest = f("rest");
    assert!(rest > 393.15 && rest < 500.0, "heat flowed out of the hot group: {rest}");
    assert!(f("max") == 500.0 && f("mean") > 393.15);
    assert!(f("g") > 0.0);
    assert_eq!(out["every"].as_int().unwrap(), 10);
    let plan = out["plan"].clone().into_string().unwrap();
    assert!(plan.contains("conduction(forward euler every 10 step(s) in 2 sub-step(s), thermal expansion)"), "{plan}");
    assert!(plan.contains("conduction 57 B (temperature, capacity, conductivity, source, conductance, thermal_mode, expansion, radius0)"), "{plan}");
    assert!(plan.contains("→ conduction → guard") && plan.contains("buoyancy"), "{plan}");
}

// A group can override its material's conductivity; a heat source warms its group; the water
// table adds the buoyancy stage (and reads back); disabling both leaves the plan without them.
#[test]
fn groups_sources_and_the_water_table_from_a_script() {
    let script = format!(
        r#"{SMALL_BOX}
        d.enable("heat");
        d.thermal("m", #{{ conductivity: 2.0, specific_heat: 800.0 }});
        d.add_group("core", d.z < 0.0015);
        d.thermal("core", #{{ conductivity: 0.0 }});
        d.heat_source("core", 1e-3);
        let before = d.temperature.select(d.in_group("core")).mean();
        d.water_level = 0.002;
        d.fluid_density = 1000.0;
        d.fluid_viscosity = 1e-3;
        d.gravity = [0.0, 0.0, -9.81];
        d.run(100);
        let after = d.temperature.select(d.in_group("core")).mean();
        let plan = d.plan();
        let level = d.water_level;
        d.disable("water");
        d.disable("heat");
        #{{ rise: after - before, plan: plan, level: level, off: d.plan(), dry: d.water_level }}"#
    );
    let out: rhai::Map = engine("fields_groups").eval(&script).unwrap_or_else(|e| panic!("{e}"));
    assert!(out["rise"].as_float().unwrap() > 0.0);
    assert_eq!(out["level"].as_float().unwrap(), 0.002);
    assert!(out["dry"].is_unit());
    let plan = out["plan"].clone().into_string().unwrap();
    assert!(plan.contains("buoyancy(water level z = 0.002 m, ρ_f = 1000 kg/m³, stokes drag"), "{plan}");
    // A force stage: before integration, so local damping sees it.
    let order = "stages: walls → neighbours → contact_forces → wall_forces → buoyancy → integrate";
    assert!(plan.contains(order), "{plan}");
    let off = out["off"].clone().into_string().unwrap();
    assert!(!off.contains(order), "{off}");
    let not_simulated = off.split("not simulated: ").nth(1).unwrap_or_default();
    assert!(not_simulated.contains("buoyancy") && not_simulated.contains("heat conduction"), "{off}");
}

// The water table in `d.energies()`: filling the table books its buoyant potential as body
// work (the total does not jump), lowering it books the change, gravity's change is body work too
// (switching it on before the first run included), and removing the water takes the potential
// back (to 1e-12 of the potential).
#[test]
fn the_water_table_and_gravity_are_booked_in_the_energy_account() {
    let script = format!(
        r#"{SMALL_BOX}
        d.gravity = [0.0, 0.0, -9.81];
        d.run(10);
        let e0 = d.energies();
        d.water_level = 0.004;
        let e1 = d.energies();
        d.water_level = 0.002;
        let e2 = d.energies();
        d.gravity = [0.0, 0.0, -12.0];
        let e3 = d.energies();
        d.disable("water");
        let e4 = d.energies();
        #{{ e0: e0, e1: e1, e2: e2, e3: e3, e4: e4 }}"#
    );
    let out: rhai::Map = engine("fields_energy").eval(&script).unwrap_or_else(|e| panic!("{e}"));
    let e = |k: &str, f: &str| out[k].clone_cast::<rhai::Map>()[f].as_float().unwrap();
    // Switching gravity on before the first run was body work already (its potential).
    let (ub, w0) = (e("e1", "buoyancy"), e("e0", "body_work"));
    assert!(ub > 0.0 && e("e0", "buoyancy") == 0.0 && w0 != 0.0);
    assert!((e("e1", "body_work") - w0 - ub).abs() < 1e-12 * ub, "filling books the potential");
    assert!(e("e2", "buoyancy") < ub && e("e2", "buoyancy") > 0.0);
    assert!((e("e2", "body_work") - w0 - e("e2", "buoyancy")).abs() < 1e-12 * ub, "lowering books the change");
    let dg = e("e3", "gravity") + e("e3", "buoyancy") - e("e2", "gravity") - e("e2", "buoyancy");
    assert!((e("e3", "body_work") - e("e2", "body_work") - dg).abs() < 1e-12 * dg.abs(), "gravity's change");
    assert!(e("e4", "buoyancy") == 0.0);
    for k in ["e1", "e2", "e3", "e4"] {
        assert!((e(k, "total") - e("e0", "total")).abs() < 1e-12 * ub, "{k}: the total jumped");
    }
}

#[test]
fn bad_field_input_is_refused_with_what_to_do() {
    let cases = [
        ("d.temperature", "d.enable(\"heat\")"),
        ("d.temperature = 300.0", "d.enable(\"heat\")"),
        ("d.enable(\"heat\"); d.temperature = [1.0, 2.0].map(|x| x) ; ", "expected a number or a Field"),
        ("d.enable(\"heat\"); d.thermal(\"granite\", #{ conductivity: 1.0 })", "neither a material nor a group"),
        ("d.enable(\"heat\"); d.thermal(\"m\", #{ conductivty: 1.0 })", "conductivity"),
        ("d.enable(\"heat\"); d.thermal(\"m\", #{ conductivity: -1.0 })", "≥ 0"),
        ("d.heat_substeps = 0", "integer from 1 to"),
        ("d.fluid_density = -1.0", "fluid_density"),
        ("d.enable(\"humidity\")", "moisture"),
        ("d.fix_temperature(\"sample\", 300.0)", "d.enable(\"heat\")"),
        // No capacity: refused before the run, naming the setting.
        ("d.enable(\"heat\"); d.run(1)", "specific_heat"),
    ];
    for (k, (call, expected)) in cases.into_iter().enumerate() {
        let e = refusal(&format!("fields_bad_{k}"), &format!("{SMALL_BOX} {call}"));
        assert!(e.contains(expected), "{call}: {e}");
    }
}

// ParaView snapshots carry the temperature when heat is on, and not otherwise.
#[test]
fn snapshots_carry_the_temperature() {
    use matdem_engine::{Material, Model, Vec3};
    let mut m = Model::new();
    let k = m.add_material(Material::from_micro("m", 2650.0, 1e5, 1e4, 0.0, 0.0, 0.5, 1e-3).unwrap()).unwrap();
    m.add_particle(Vec3::zeros(), 1e-3, k).unwrap();
    assert!(!matdem_rs::snapshot::vtp(&m).contains("temperature"));
    m.enable_heat();
    m.set_temperatures(&[321.5]).unwrap();
    let vtp = matdem_rs::snapshot::vtp(&m);
    assert!(vtp.contains("Name=\"temperature\"") && vtp.contains("321.5"), "{vtp}");
}

// A particle picture by temperature: `d.show("temperature", name)` colours the elements by
// their temperature with the unit in the colour bar; without heat on it is refused with what
// to call first.
#[test]
fn a_particle_picture_shows_the_temperature_field() {
    let dir = crate::common::temp_dir("show_temperature");
    let script = format!(
        r#"{SMALL_BOX}
        d.enable("heat");
        d.temperature = 300.0 + d.z * 1e4;
        d.show("temperature", "temperature");"#
    );
    matdem_rs::new_engine(Rc::new(Host::new(dir.clone()))).run(&script).unwrap_or_else(|e| panic!("{e}"));
    let svg = std::fs::read_to_string(dir.join("temperature.svg")).unwrap();
    assert!(svg.contains("temperature [K]"), "the colour bar names the field and its unit");
    assert!(dir.join("temperature.png").is_file());

    let e = refusal("show_temperature_off", &format!("{SMALL_BOX}\nd.show(\"temperature\", \"t\");"));
    assert!(e.contains("no temperature field") && e.contains("d.enable(\"heat\")"), "{e}");
}

// Moisture on: every element starts at d.initial_water; a sealed, fixed-free box conserves
// Σ m·ω; evaporation from the top dries it by what leaves the top; the radius table shrinks the
// elements; the plan names the stage and its lanes; records carry mean and total water; the
// picture names the field and its unit.
#[test]
fn moisture_from_a_script_diffuses_dries_shrinks_and_is_recorded() {
    let dir = crate::common::temp_dir("moisture_script");
    let script = format!(
        r#"{SMALL_BOX}
        d.r = d.r * 1.1;
        d.initial_water = 0.25;
        d.enable("moisture");
        let w0 = d.water.mean();
        d.moisture("m", #{{ diffusivity: 1e-3 }});
        d.water = 0.1 + d.z * 50.0;
        let total0 = d.total_water;
        d.run(50);
        let total1 = d.total_water;
        d.add_group("top", d.z > 0.002);
        d.evaporate("top", #{{ transfer: 1e-3, ambient: 0.02 }});
        d.water_radius_table = [[0.0, 0.95], [0.3, 1.0]];
        let r0 = d.r;
        d.moisture_every = 5;
        d.moisture_substeps = 2;
        d.run(200);
        d.record();
        d.show("water", "water");
        let shrink = (d.r / r0).mean();
        #{{ w0: w0, total0: total0, total1: total1, total2: d.total_water, plan: d.plan(), shrink: shrink,
            mean: d.status["mean_water"][0], total: d.status["total_water"][0], table: d.water_radius_table.len() }}"#
    );
    let out: rhai::Map =
        matdem_rs::new_engine(Rc::new(Host::new(dir.clone()))).eval(&script).unwrap_or_else(|e| panic!("{e}"));
    let f = |k: &str| out[k].as_float().unwrap();
    assert!((f("w0") - 0.25).abs() < 1e-15, "{}", f("w0"));
    assert!(((f("total1") - f("total0")) / f("total0")).abs() < 1e-12, "{} against {}", f("total1"), f("total0"));
    assert!(f("total2") < f("total1"), "evaporation dried it");
    assert!((f("total") - f("total2")).abs() < 1e-12 * f("total2"));
    assert!(f("mean") > 0.02 && f("mean") < 0.3);
    assert!(f("shrink") < 1.0, "the radius table shrank the elements: {}", f("shrink"));
    let plan = out["plan"].clone().into_string().unwrap();
    assert!(plan.contains("moisture(forward euler every 5 step(s) in 2 sub-step(s), drying shrinkage)"), "{plan}");
    assert!(
        plan.contains("moisture 49 B (water, diffusivity, transfer, ambient, conductance, mode, radius0)"),
        "{plan}"
    );
    assert_eq!(out["table"].as_int().unwrap(), 2);
    let svg = std::fs::read_to_string(dir.join("water.svg")).unwrap();
    assert!(svg.contains("water content [kg/kg]"));
}

#[test]
fn bad_moisture_input_is_refused_with_what_to_do() {
    let cases = [
        ("d.water", "d.enable(\"moisture\")"),
        ("d.water = 0.2", "d.enable(\"moisture\")"),
        ("d.enable(\"moisture\"); d.water = -0.1", "≥ 0"),
        ("d.enable(\"moisture\"); d.moisture(\"clay\", #{ diffusivity: 1.0 })", "neither a material nor a group"),
        ("d.enable(\"moisture\"); d.moisture(\"m\", #{ difusivity: 1.0 })", "diffusivity"),
        ("d.enable(\"moisture\"); d.evaporate(\"sample\", #{ ambient: 0.1 })", "transfer"),
        ("d.water_radius_table = [[0.3, 1.0], [0.1, 0.9]]", "increase"),
        ("d.water_strength_table = [[0.0, 1.5]]", "(0, 1]"),
        ("d.water_strength_table = [0.0, 1.0]", "[[water content, value]"),
        ("d.moisture_substeps = 0", "integer from 1 to"),
        ("d.seal(\"sample\")", "d.enable(\"moisture\")"),
        ("d.show(\"water\", \"w\")", "no water field"),
    ];
    for (k, (call, expected)) in cases.into_iter().enumerate() {
        let e = refusal(&format!("moisture_bad_{k}"), &format!("{SMALL_BOX} {call}"));
        assert!(e.contains(expected), "{call}: {e}");
    }
}

// ParaView snapshots carry the water content when moisture is on, and not otherwise.
#[test]
fn snapshots_carry_the_water_content() {
    use matdem_engine::{Material, Model, Vec3};
    let mut m = Model::new();
    let k = m.add_material(Material::from_micro("m", 2650.0, 1e5, 1e4, 0.0, 0.0, 0.5, 1e-3).unwrap()).unwrap();
    m.add_particle(Vec3::zeros(), 1e-3, k).unwrap();
    assert!(!matdem_rs::snapshot::vtp(&m).contains("\"water\""));
    m.enable_moisture();
    m.set_water(&[0.1875]).unwrap();
    let vtp = matdem_rs::snapshot::vtp(&m);
    assert!(vtp.contains("Name=\"water\"") && vtp.contains("0.1875"), "{vtp}");
}
