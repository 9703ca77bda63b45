//! Every optional stage of the engine's registry (`plan/mod.rs`, `REGISTRY`) is switched on from a
//! script by the switch its row names: on a small packing the plan's stage list lacks the stage
//! before the switch and has it after. A stage added to the registry without a script switch,
//! or with one that does not reach the plan, fails here.

use crate::common::SMALL_BOX;
use matdem_engine::plan::REGISTRY;
use matdem_rs::api::Host;
use std::rc::Rc;

/// Per effect: what turns it off first (the heat ledger is on by default) and the script that
/// switches it on, which uses the registry row's switch.
const SWITCHES: [(&str, &str, &str); 11] = [
    (
        "parallel_bond",
        "",
        r#"d.connect("sample", 1e-4);
        d.bond_parallel(#{ lambda: 1.0, e_star: 1e8, k_ratio: 2.6, sigma_c: 1e6, c: 1e6, phi: 30.0 });"#,
    ),
    ("rolling_resistance", "", r#"d.rolling_resistance = #{ model: "cdt", mu_r: 0.1 };"#),
    ("pore_flow", "", r#"d.fluid = #{ bulk_modulus: 1e5, viscosity: 1.0 }; d.enable("pore_flow");"#),
    ("applied_loads", "", "d.apply_force([0], [1e-4, 0.0, 0.0]);"),
    (
        "confining_pressure",
        "",
        r#"d.place_boundary("top_platen", [0.0, 0.0, (d.z + d.r).max()]);
        d.confine(#{ pressure: 1e4, axis: [0.002, 0.002] });"#,
    ),
    ("buoyancy", "", "d.water_level = 0.002;"),
    ("heat_ledger", "d.heat_ledger = false;", "d.heat_ledger = true;"),
    ("conduction", "", r#"d.enable("heat");"#),
    ("moisture", "", r#"d.enable("moisture");"#),
    ("clumps", "", "d.clump([0, 1]);"),
    ("periodic", "", "d.periodic(#{ x: [0.0, 0.004] });"),
];

/// The names on the plan's `stages:` line.
fn stages(plan: &str) -> Vec<String> {
    let line =
        plan.lines().find_map(|l| l.strip_prefix("stages: ")).unwrap_or_else(|| panic!("no stages line in\n{plan}"));
    line.split(" → ").map(str::to_string).collect()
}

#[test]
fn every_registered_effect_is_switched_on_by_its_script_switch() {
    let effects: Vec<_> = REGISTRY.iter().filter(|e| e.effect).collect();
    assert_eq!(effects.len(), SWITCHES.len(), "a registered effect without its switch in SWITCHES (or one too many)");
    for e in effects {
        let (_, off, on) = SWITCHES
            .iter()
            .find(|(name, ..)| *name == e.name)
            .unwrap_or_else(|| panic!("{}: no script in SWITCHES switches it on", e.name));
        assert!(on.contains(e.script), "{}: the script does not use the registered switch `{}`", e.name, e.script);
        let engine = matdem_rs::new_engine(Rc::new(Host::new(crate::common::temp_dir("stage_switches"))));
        let script = format!("{SMALL_BOX}\n{off}\nlet before = d.plan();\n{on}\n[before, d.plan()]");
        let plans = engine.eval::<rhai::Array>(&script).unwrap_or_else(|err| panic!("{}: {err}", e.name));
        let [before, after] = [&plans[0], &plans[1]].map(|p| stages(&p.clone().into_string().unwrap()));
        assert!(!before.iter().any(|s| s == e.name), "{}: on before its switch: {before:?}", e.name);
        assert!(after.iter().any(|s| s == e.name), "{}: `{on}` did not put it in the plan: {after:?}", e.name);
    }
}
