//! Issue 16 from a script: `d.enable("pore_flow")`, `d.fluid`, the boundary calls
//! (`d.fix_pore_pressure` with a group or a box, `d.inject`, `d.fix_pore_pressure_at`,
//! `d.seal_pores`), the readings (`d.pore_pressure` per element, `d.pore_pressures` per pore,
//! `d.permeability`, `d.pore_network`), `d.plan()` listing the stage, and the refusals of bad
//! input with what to do instead.

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

// Fluid injected at the centre of a sealed box: the mass the network holds grows by
// ρ0·rate·t (to round-off of its total), the pressure rises; the plan names the stage.
#[test]
fn pore_flow_from_a_script_injects_conserves_and_reports() {
    let script = format!(
        r#"{SMALL_BOX}
        let plan_off = d.plan();
        d.fluid = #{{ bulk_modulus: 1e5, viscosity: 1.0 }};
        d.enable("pore_flow");
        let net0 = d.pore_network;
        let k = d.permeability;
        d.inject([0.002, 0.002, 0.0015], 1e-12);
        let dt = d.dt;
        d.run(200);
        let net = d.pore_network;
        let p = d.pore_pressure;
        #{{ plan_off: plan_off, plan: d.plan(), m0: net0.fluid_mass, m1: net.fluid_mass, added: net.boundary_mass,
            want: 1000.0 * 1e-12 * 200.0 * dt, pmax: p.max(), pmin: p.min(), n: p.len(), count: d.r.len(),
            pores: d.pore_pressures.len(), npores: net.pores, kx: k.x, ky: k.y, kz: k.z, porosity: k.porosity,
            fluid: d.fluid }}"#
    );
    let out: rhai::Map = engine("pore_script").eval(&script).unwrap_or_else(|e| panic!("{e}"));
    let f = |k: &str| out[k].as_float().unwrap();
    let plan_off = out["plan_off"].clone().into_string().unwrap();
    assert!(!plan_off.contains("pore_flow") && plan_off.contains("fluid flow"), "{plan_off}");
    let plan = out["plan"].clone().into_string().unwrap();
    assert!(plan.contains("→ pore_flow → integrate") && plan.contains("1 flux region"), "{plan}");
    let (m0, m1, added, want) = (f("m0"), f("m1"), f("added"), f("want"));
    println!("fluid mass {m0:e} → {m1:e}, injected {added:e} (ρ0·q·t = {want:e})");
    assert!((added / want - 1.0).abs() < 1e-12, "injected {added:e} vs {want:e}");
    // Conserved to round-off of the network's total.
    assert!((m1 - m0 - added).abs() < 1e-12 * m0, "the network gained {:e} of {added:e}", m1 - m0);
    assert!(f("pmax") > 0.0 && f("pmax") > f("pmin"), "{} .. {}", f("pmin"), f("pmax"));
    assert_eq!(out["n"].as_int().unwrap(), out["count"].as_int().unwrap());
    assert_eq!(out["pores"].as_int().unwrap(), out["npores"].as_int().unwrap());
    for a in ["kx", "ky", "kz"] {
        assert!(f(a) > 0.0, "{a} = {}", f(a));
    }
    assert!(f("porosity") > 0.0 && f("porosity") < 1.0);
    let fluid = out["fluid"].clone().cast::<rhai::Map>();
    assert_eq!(fluid["bulk_modulus"].as_float().unwrap(), 1e5);
    assert_eq!(fluid["density"].as_float().unwrap(), 1000.0);
}

// A drained face from a group and a box: the pores there hold their pressure; seal_pores
// removes every region; disable drops the network.
#[test]
fn pore_boundaries_from_groups_boxes_and_points() {
    let script = format!(
        r#"{SMALL_BOX}
        d.fluid = #{{ bulk_modulus: 1e5, viscosity: 1.0 }};
        d.add_group("low", d.z < 0.0008);
        d.fix_pore_pressure("low", 500.0);
        d.fix_pore_pressure(#{{ lo: [0.0, 0.0, 0.0025], hi: [0.004, 0.004, 1.0] }}, 0.0);
        d.enable("pore_flow");
        d.run(50);
        let p = d.pore_pressures;
        let held = 0;
        for x in p {{ if (x - 500.0).abs() < 1e-6 {{ held += 1; }} }}
        let plan = d.plan();
        d.seal_pores();
        d.fix_pore_pressure_at([0.002, 0.002, 0.0015], 100.0);
        let plan2 = d.plan();
        d.seal_pores();
        d.fix_pore_pressure(#{{ center: [0.002, 0.002, 0.002], axis: [0, 1, 0], radius: 0.001 }}, 300.0);
        d.run(5);
        let bore = 0;
        for x in d.pore_pressures {{ if (x - 300.0).abs() < 1e-6 {{ bore += 1; }} }}
        d.disable("pore_flow");
        #{{ held: held, plan: plan, plan2: plan2, bore: bore, off: d.plan() }}"#
    );
    let out: rhai::Map = engine("pore_bounds").eval(&script).unwrap_or_else(|e| panic!("{e}"));
    assert!(out["held"].as_int().unwrap() > 0);
    let plan = out["plan"].clone().into_string().unwrap();
    assert!(plan.contains("2 fixed-pressure"), "{plan}");
    let plan2 = out["plan2"].clone().into_string().unwrap();
    assert!(plan2.contains("1 fixed-pressure"), "{plan2}");
    assert!(out["bore"].as_int().unwrap() > 0, "no pore held in the borehole");
    let off = out["off"].clone().into_string().unwrap();
    assert!(!off.contains("pore_flow"), "{off}");
}

#[test]
fn bad_pore_flow_input_is_refused_with_what_to_do() {
    let e = refusal("fluid_neg", &format!("{SMALL_BOX} d.fluid = #{{ bulk_modulus: -1.0 }};"));
    assert!(e.contains("bulk_modulus") && e.contains("nothing was changed") && e.contains("water"), "{e}");
    let e = refusal("fluid_key", &format!("{SMALL_BOX} d.fluid = #{{ viscosty: 1.0 }};"));
    assert!(e.contains("viscosity"), "{e}");
    let e = refusal("fluid_sub", &format!("{SMALL_BOX} d.fluid = #{{ max_substeps: 0 }};"));
    assert!(e.contains("max_substeps"), "{e}");
    let e = refusal("pp_off", &format!("{SMALL_BOX} d.pore_pressure"));
    assert!(e.contains("d.enable(\"pore_flow\")"), "{e}");
    let e = refusal(
        "box_bad",
        &format!("{SMALL_BOX} d.fix_pore_pressure(#{{ lo: [1.0, 0.0, 0.0], hi: [0.0, 1.0, 1.0] }}, 0.0);"),
    );
    assert!(e.contains("`lo` corner"), "{e}");
    let e = refusal(
        "bore_bad",
        &format!(
            "{SMALL_BOX} d.fix_pore_pressure(#{{ center: [0.0, 0.0, 0.0], axis: [0, 1, 0], radius: -1.0 }}, 0.0);"
        ),
    );
    assert!(e.contains("radius") && e.contains("above 0"), "{e}");
    let e = refusal(
        "bore_axis",
        &format!("{SMALL_BOX} d.fix_pore_pressure(#{{ center: [0.0, 0.0, 0.0], axis: [0, 0, 0], radius: 1.0 }}, 0.0);"),
    );
    assert!(e.contains("non-zero axis"), "{e}");
    let e = refusal(
        "bore_miss",
        &format!("{SMALL_BOX} d.fix_pore_pressure(#{{ center: [0.0, 0.0, 0.0], radius: 1.0 }}, 0.0);"),
    );
    assert!(e.contains("`axis` is missing"), "{e}");
    let e = refusal("group_bad", &format!("{SMALL_BOX} d.fix_pore_pressure(\"nosuch\", 0.0);"));
    assert!(e.contains("nosuch"), "{e}");
    let e = refusal("inject_nan", &format!("{SMALL_BOX} d.inject([0.0, 0.0, 0.0], 0.0 / 0.0);"));
    assert!(e.contains("finite"), "{e}");
    // An unstable flow stops the run naming the pore and the fix.
    let e = refusal(
        "unstable",
        &format!("{SMALL_BOX} d.fluid = #{{ bulk_modulus: 2.2e9, viscosity: 1e-3, max_substeps: 2 }}; d.enable(\"pore_flow\"); d.run(5);"),
    );
    assert!(e.contains("pore ") && e.contains("max_substeps") && e.contains("bulk_modulus"), "{e}");
}

// Heat with pore flow from a script: hot fluid injected at a temperature warms the pores and
// the grains, the regions book the heat and mass, the fluid's thermal keys read back, a
// material's permeability factor is taken, and `d.export_pores` writes the network as a
// ParaView file in the output folder (pores as points, throats as lines).
#[test]
fn pore_fluid_heat_and_the_pore_network_file_from_a_script() {
    let dir = crate::common::temp_dir("pore_heat_script");
    let script = format!(
        r#"{SMALL_BOX}
        d.enable("heat");
        d.thermal("m", #{{ conductivity: 3.0, specific_heat: 800.0 }});
        d.fluid = #{{ bulk_modulus: 1e5, viscosity: 1.0, specific_heat: 4186.0, expansion: 3e-4, nusselt: 2.0,
                      permeability: #{{ m: 0.5 }} }};
        d.enable("pore_flow");
        let t0 = d.reference_temperature;
        d.inject([0.002, 0.002, 0.0015], 1e-7, t0 + 60.0);
        d.run(200);
        let net = d.pore_network;
        let path = d.export_pores("network");
        #{{ plan: d.plan(), tmax: field(d.pore_temperatures).max(), tp: d.pore_temperature.max(), t0: t0,
            grains: d.temperature.max(), injected: net.region_heat[0], mass: net.region_mass[0],
            dt: d.dt, fluid: d.fluid, path: path, pores: net.pores, throats: net.throats }}"#
    );
    let out: rhai::Map =
        matdem_rs::new_engine(Rc::new(Host::new(dir.clone()))).eval(&script).unwrap_or_else(|e| panic!("{e}"));
    let f = |k: &str| out[k].as_float().unwrap();
    let plan = out["plan"].clone().into_string().unwrap();
    assert!(plan.contains("fluid temperature: in the equation of state"), "{plan}");
    let t0 = f("t0");
    assert!(f("tmax") > t0 + 1.0 && f("tmax") <= t0 + 60.0 + 1e-9, "hottest pore {}", f("tmax"));
    assert!(f("tp") > t0 && f("grains") > t0, "the injection warmed no element: {} {}", f("tp"), f("grains"));
    let want = 1000.0 * 1e-7 * 200.0 * f("dt");
    assert!((f("mass") / want - 1.0).abs() < 1e-10, "injected mass {} vs ρ0·q·t {want}", f("mass"));
    assert!((f("injected") / (4186.0 * want * 60.0) - 1.0).abs() < 1e-10, "injected heat {}", f("injected"));
    let fluid = out["fluid"].clone().cast::<rhai::Map>();
    assert_eq!(fluid["expansion"].as_float().unwrap(), 3e-4);
    let perm = fluid["permeability"].clone().cast::<rhai::Map>();
    assert_eq!(perm["m"].as_float().unwrap(), 0.5);
    // The file: in the output folder, a PolyData with a point per pore and a line per throat.
    let path = std::path::PathBuf::from(out["path"].clone().into_string().unwrap());
    assert_eq!(path, dir.join("network.vtp"));
    let text = std::fs::read_to_string(&path).unwrap();
    let (np, nt) = (out["pores"].as_int().unwrap(), out["throats"].as_int().unwrap());
    assert!(text.contains(&format!("NumberOfPoints=\"{np}\"")) && text.contains(&format!("NumberOfLines=\"{nt}\"")));
    for name in ["pressure", "density", "temperature", "volume", "conductance", "flux"] {
        assert!(text.contains(&format!("Name=\"{name}\"")), "no {name} array");
    }
    let values = |name: &str| -> usize {
        let start = text.find(&format!("Name=\"{name}\"")).unwrap();
        let body = &text[start..];
        let body = &body[body.find('>').unwrap() + 1..body.find("</DataArray>").unwrap()];
        body.split_whitespace().count()
    };
    assert_eq!(values("temperature") as i64, np);
    assert_eq!(values("flux") as i64, nt);
    assert_eq!(values("connectivity") as i64, 2 * nt);
    // Only into the output folder, and only with pore flow on.
    let e = refusal("pores_out", &format!("{SMALL_BOX} d.enable(\"pore_flow\"); d.export_pores(\"../x\");"));
    assert!(e.contains("..") || e.contains("output"), "{e}");
    let e = refusal("pores_off", &format!("{SMALL_BOX} d.export_pores(\"x\");"));
    assert!(e.contains("d.enable(\"pore_flow\")"), "{e}");
    let e = refusal("pores_ext", &format!("{SMALL_BOX} d.enable(\"pore_flow\"); d.export_pores(\"x.csv\");"));
    assert!(e.contains(".vtp"), "{e}");
    let e = refusal("perm_bad", &format!("{SMALL_BOX} d.fluid = #{{ permeability: #{{ m: -1.0 }} }};"));
    assert!(e.contains("permeability factor") && e.contains("nothing was changed"), "{e}");
}
