//! The script API under random bad values — NaN, ±inf, zero and negative sizes, huge
//! counts, empty groups and masks, wrong types, unknown names — in process: every call ends
//! in a value or a script error, never a panic or an abort, and leaves every position,
//! velocity and radius of the model finite (a value that would overflow a step is refused
//! before the run, not found as a NaN after it). Prints how many cases ran.

use matdem_rs::api::Host;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::rc::Rc;
use std::sync::atomic::Ordering;

/// A small unsettled model `d` and a box builder `b` (not yet built).
const SCENE: &str = r#"
let b = new_box("t");
b.sample_w = 0.003; b.sample_l = 0.003; b.sample_h = 0.002; b.ball_r = 0.4e-3; b.seed = 3;
b.set_type("top_platen");
let d = new_box("u");
d.sample_w = 0.003; d.sample_l = 0.003; d.sample_h = 0.002; d.ball_r = 0.4e-3; d.seed = 4;
d.set_type("top_platen");
let d = d.build_initial_model();
d.set_group_mat("sample", material_micro("m", #{ kn: 2e5, ks: 8e4, mu_p: 0.3, r: 0.4e-3, restitution: 0.3 }));
d.set_standard_dt();
"#;

/// Bad (and a few good) values, as Rhai source.
const VALUES: &[&str] = &[
    "(0.0/0.0)",
    "(1.0/0.0)",
    "(-1.0/0.0)",
    "0.0",
    "-1.0",
    "-1e-300",
    "1e-300",
    "1e308",
    "0",
    "-5",
    "7",
    "9223372036854775807",
    "-9223372036854775807",
    "\"\"",
    "\"no_such_name\"",
    "\"sample\"",
    "\"top_platen\"",
    "\"z\"",
    "()",
    "[]",
    "[1.0]",
    "[1.0, (0.0/0.0), 3.0]",
    "#{}",
    "true",
    "d.z > 100.0",
    "d.z < 100.0",
    "[[0.0, 0.0, 1.0]]",
    "[[1e-3, 0.5e-3, 1.0]]",
    "field([])",
    "d.r",
];

/// True when every element's position, velocity and radius is finite.
const FINITE: &str = "[d.x, d.y, d.z, d.vx, d.vy, d.vz, d.r].all(|f| f.is_finite().count() == d.n)";

/// Calls with two holes, A and B.
const CALLS: &[&str] = &[
    "b.ball_r = A; b.build_initial_model()",
    "b.sample_w = A; b.sample_h = B; b.build_initial_model()",
    "b.sample_r = A; b.build_initial_model()",
    "b.distri_rate = A; b.build_initial_model()",
    "b.gradation = A; b.build_initial_model()",
    "b.porosity = A; b.build_initial_model()",
    "b.seed = A; b.set_type(B)",
    "material(\"m\", #{ E: A, nu: B, Tu: 1e6, Cu: 1e6, mu_i: 0.5 })",
    "material(\"m\", #{ E: 1e9, nu: 0.1, Tu: A, Cu: B, mu_i: 0.5, d: 1e-3 })",
    "material_micro(\"m\", #{ kn: A, ks: B, r: 1e-3 })",
    "material_micro(\"m\", #{ kn: 1e5, ks: 1e4, r: A, density: B })",
    "d.set_group_mat(A, material_micro(\"m\", #{ kn: 1e5, ks: 1e4, r: 1e-3, restitution: B }))",
    "d.run(A)",
    "d.balance(A)",
    "d.balance(\"standard\", A)",
    "d.balance(A, B)",
    "d.balance_until(A, B)",
    "d.dt = A; d.run(20)",
    "d.gravity = [A, B, 0.0]; d.run(20)",
    "d.gravity = A",
    "d.damping = A; d.local_damping = B; d.run(20)",
    "d.contact_law = A; d.shear_law = B",
    "d.rolling_resistance = A; d.run(20)",
    "d.rolling_resistance = #{ model: A, mu_r: B }; d.run(20)",
    "d.add_group(A, B)",
    "d.add_group(\"g\", A); d.fix(\"g\", B)",
    "d.free(A, B)",
    "d.set_velocity(A, [B, 0.0, 0.0]); d.run(20)",
    "d.set_velocity(\"sample\", A)",
    "d.connect(A, B)",
    "d.break_bonds(A)",
    "d.remove(A); d.run(20)",
    "d.group(A)",
    "d.group_where(A, B)",
    "d.in_group(A)",
    "d.enable(A)",
    "d.move_boundary(A, [0.0, 0.0, B]); d.run(20)",
    "d.move_boundary(\"top_platen\", A)",
    "d.place_boundary(A, B)",
    "d.set_platen_stress(A, B); d.run(20)",
    "d.set_platen_stress(\"top_platen\", A, B); d.run(20)",
    "d.set_boundary_friction(A, B)",
    "d.stop_boundary(A)",
    "d.boundary(A)",
    "d.porosity_box(A, B)",
    "d.porosity_cylinder(A, B, 1.0)",
    "d.record(A)",
    "d.show(A, \"p\")",
    "d.show(\"z\", \"p\", A)",
    "d.show(d.r, A, B)",
    "plot(d.status, A, B)",
    "plot(A, B)",
    "chart(\"t\", \"x\", \"y\").series(\"s\", A, B).save(\"c\")",
    "field(A).mean()",
    "zeros(A)",
    "d.z.select(A)",
    "d.z[A]",
    "(d.z / A).max()",
    "(d.z * A + B).sum()",
    "A.sqrt()",
    "d.z.clamp(A, B)",
    "where(d.z > 0.001, A, B)",
    "min(A, B).sum()",
    "max(d.z, A).mean()",
    "pow(d.z - 0.001, A)",
    "(d.z * A).exp().ln().log10()",
    "fmt(A, B)",
    "report(A, B)",
    "new_table().add_row(#{ a: A })",
    "let t = new_table(); t.add_row(#{ a: 1.0 }); t[A]",
    "let t = new_table(); t.last(A)",
    "load_table(A)",
    "read_text(A)",
    "d.x = A; d.run(20)",
    "d.r = A; d.run(20)",
    "d.set(A, B, 1e-3)",
    "d.set(\"r\", A, B); d.run(20)",
    "d.set(\"z\", A, B); d.run(20)",
    "d.set(\"vx\", \"sample\", A)",
    "d.wx = A",
    "d.delete(A); d.run(20)",
    "d.keep_groups(A)",
    "d.keep_groups([A, B]); d.run(20)",
    "d.move_group(A, B, 0.0, 0.0); d.run(20)",
    "d.freeze(A); d.unfreeze(B); d.run(20)",
    "d.in_box(A, B, 0, 1, 0, 1).count()",
    "d.in_sphere(A, 0, 0, B)",
    "d.in_cylinder(0, 0, A, B, 1)",
    "d.above_plane(A, B)",
    "d.layers_between(A)",
    "d.layers_between(A, B)",
    "d.add_elements(new_table(), A, B)",
    "let t = new_table(); t.add_row(#{ x: A, y: 0.0, z: 0.001, r: B }); d.add_elements(t, \"m\", \"n\"); d.run(20)",
    "make_box(A, 0.002, 0.002, B)",
    "make_column(A, 0.002, B, \"hcp\").n",
    "make_ring(A, B, 0.002, 2e-4)",
    "make_sphere(A, B)",
    "make_disc(A, 2e-4)",
    "make_lattice(A, B, 2, 2, 1e-3)",
    "make_lattice(\"sc\", A, 2, B, 1e-3)",
    "make_lattice(\"fcc\", 2, 2, 2, 1e-3).rotated(A, B)",
    "make_lattice(\"fcc\", 2, 2, 2, 1e-3).moved(A, B, 0.0).filter(A)",
    "geometry(A, B, [0.0], 1e-4)",
    "d.add_elements(geometry([A], [B], [0.001], 1e-4), \"m\", \"g\"); d.run(20)",
    "cut_surface([[A, 0.0, 0.0], [0.001, B, 0.0], [0.0, 0.001, 0.001]])",
    "d.cut_above(cut_surface(A))",
    "d.cut_below(cut_surface([[0.0, 0.0, A], [0.003, 0.0, B], [0.0, 0.003, 0.001]])); d.run(20)",
    "d.layers_between([A, cut_surface([[0.0, 0.0, 0.0], [1.0, 0.0, B], [0.0, 1.0, 0.0]])])",
    "d.connect(\"sample\", 1e-4); d.set_joint([0.0, 0.0, A], [0.0, 0.0, 1.0], B); d.run(20)",
    "d.in_polygon([[A, 0.0], [0.003, B], [0.0, 0.003]], 0.0, 0.002).count()",
    "d.connect(A, B, 1e-4)",
    "field([1.0, 2.0]).percentile(A) + B.percentile(50)",
    "B.histogram(A)",
    "d.porosity_box([0.0, 0.0, A], [0.003, 0.003, B])",
    "d.mechanical_coordination()",
    "sediment(d, #{ accel: A, max_steps: B })",
    "stage_load(d, A, B, #{ max_steps: 50 })",
    "compact(d, A, #{ max_steps: 50 })",
    // The calls added since the list above was written (effects, 2D, periodic cells,
    // clumps, loads, fields, analysis): the same promise for each.
    "let s = cut_surface([[0.0, 0.0, A], [0.003, 0.0, B], [0.0, 0.003, 0.001]]); d.above_surface(s).count() + d.below_surface(s).count()",
    "field(A).abs().floor().round().is_finite().count()",
    "d.add_cone(#{ name: \"c\", apex: [0.0015, 0.0015, A], angle: B, radius: 3e-4, rod_length: 1e-3 }); d.run(20)",
    "d.add_strip(#{ name: \"s\", point: [0.0, 0.0, 0.0], normal: [1.0, 0.0, 0.0], axis: [0.0, 0.0, 1.0], from: A, to: B }); d.run(20)",
    "anova_oneway([field([1.0, 2.0, 3.0]), A])",
    "anova_oneway(A)",
    "d.apply_force(A, [B, 0.0, 0.0]); d.run(20)",
    "d.apply_torque(\"sample\", A); d.run(20); d.clear_applied_loads()",
    "d.connect(\"sample\", 1e-4); d.bond_parallel(#{ lambda: A, e_star: B, k_ratio: 2.5, sigma_c: 1e6, c: 1e6, phi: 30.0 }); d.run(20)",
    "d.connect(\"sample\", 1e-4); d.bond_parallel(#{ lambda: 1.0, e_star: 1e8, k_ratio: A, sigma_c: B, c: 1e6, phi: 30.0 }); d.run(20)",
    "d.bond_parallel(A)",
    "make_box(1e-3, 1e-3, 1e-3, A).bounds()",
    "d.clump(A); d.run(20)",
    "let c = d.clump(d.z < 0.0006); d.clump_info(A); d.run(20)",
    "d.clump_info(A)",
    "make_box(1e-3, 1e-3, 1e-3, 2e-4).combine(A).copy().to_table()",
    "combine([make_disc(A, 2e-4), make_disc(1e-3, B)])",
    "d.confine(#{ pressure: A, bottom: \"bottom\", top: \"top_platen\", bands: B }); d.run(20); d.membrane(); d.unconfine()",
    "d.confine(A)",
    "d.contacts(A).len()",
    "d.critical_dt() + d.standard_dt() + d.coordination_number() + d.mean_contact_force() + d.unbalanced_ratio()",
    "d.disable(A)",
    "d.energies()[A]",
    "d.enable(\"heat\"); d.thermal(\"sample\", #{ conductivity: A, specific_heat: B, expansion: 1e-5 }); d.run(20)",
    "d.enable(\"heat\"); d.thermal(A, #{ conductivity: 1.0, specific_heat: 800.0 }); d.fix_temperature(\"sample\", B); d.run(20)",
    "d.enable(\"heat\"); d.thermal(\"sample\", #{ conductivity: 1.0, specific_heat: 800.0 }); d.heat_source(A, B); d.run(20); d.insulate(A)",
    "d.enable(\"heat\"); d.thermal(\"sample\", #{ conductivity: 1.0, specific_heat: 800.0 }); d.fix_temperature(A); d.free_temperature(B); d.run(20)",
    "d.enable(\"moisture\"); d.moisture(\"sample\", #{ diffusivity: A }); d.fix_water(\"sample\", B); d.run(20)",
    "d.enable(\"moisture\"); d.moisture(A, #{ diffusivity: 1e-6 }); d.evaporate(\"sample\", #{ transfer: B, ambient: 0.1 }); d.run(20); d.free_water(A)",
    "d.export_elements(A)",
    "d.export_pores(A)",
    "d.fabric(A)",
    "d.fix_pore_pressure(A, B); d.run(20)",
    "d.fix_pore_pressure_at([A, 0.001, 0.001], B); d.run(20)",
    "d.inject([0.0015, 0.0015, 0.001], A); d.run(20); d.seal(B)",
    "d.inject(\"sample\", A, B); d.run(20)",
    "d.seal_pores(); d.run(20)",
    "d.kill(A); d.run(20)",
    "d.periodic(#{ x: [-0.001, 0.004], z: [-0.001, 0.004] }); d.lees_edwards(A); d.run(20)",
    "d.periodic(#{ x: [-0.001, A], y: [-0.001, 0.004], z: [-0.001, B] }); d.run(20); d.periodic_cell(); d.unperiodic()",
    "d.periodic(#{ x: [-0.001, 0.004], z: [-0.001, 0.004], shear_rate: A }); d.lees_edwards(B); d.run(20)",
    "d.periodic(A)",
    "d.limit_boundary(A, [0.0, 0.0, 1.0], B, 1e-3); d.run(20)",
    "d.remove_boundary(A); d.run(20)",
    "d.set_boundary_area(A, B)",
    "linspace(A, B, 5).median() + linspace(0.0, 1.0, A).len()",
    "field([1.0, 2.0, 3.0]).percentiles(A)",
    "let q = new_box(\"q\"); q.sample_w = A; q.sample_l = 0.0; q.sample_h = 0.002; q.ball_r = B; q.build_initial_model().dimension()",
    "let q = new_box(\"q\"); q.sample_w = 0.003; q.sample_l = 0.0; q.sample_h = 0.002; q.ball_r = 0.4e-3; let q = q.build_initial_model(); q.set_group_mat(\"sample\", material_micro(\"m\", #{ kn: 2e5, ks: 8e4, r: 0.4e-3 })); q.set_standard_dt(); q.make_2d(#{ thickness: A }); q.run(B)",
    "make_annulus(A, B, 2e-4).n",
    "make_tube(1e-3, A, 1e-3, B).n",
    "material_2d(\"m\", #{ E: A, nu: B, Tu: 1e6, Cu: 1e7, mu_i: 0.5, d: 1e-3 })",
    "plane_strain(#{ E: A, nu: B, Tu: 1e6, Cu: 1e7, mu_i: 0.5 })",
    "d.measure(A)",
    "d.measure(#{ lo: [0.0, 0.0, A], hi: [0.003, 0.003, B] })",
    "mohr_coulomb(A, B)",
    "shear_envelope(A, B)",
    "mohr_coulomb([1e5, 2e5], [A, B])",
    "d.movie_every(A, \"z\", \"m\"); d.run(20); d.movie_end()",
    "d.movie_every(5, A, B); d.run(20); d.movie_end()",
    "orthogonal_array(A, B)",
    "orthogonal_design(A, B)",
    "random_field(A, B).mean()",
    "random_field(100, 1, \"weibull\", A).mean()",
    "random_field(10, A, B).mean()",
    "regress(A, B)",
    "regress([1.0, 2.0, 3.0], [2.0, 4.0, 6.1], A)",
    "least_squares(|x| [x[0] - 1.0], A, #{ max_iterations: B })",
    "d.replace_with_clumps(A, B)",
    "d.rose(A)",
    "d.rose(\"contact_normal\", #{ bins: A, plane: B })",
    "d.rotate_group(A, [0.0, 0.0, 1.0], B, [0.0, 0.0, 0.0]); d.run(20)",
    "d.rotate_group(\"sample\", A, 30.0, B)",
    "scale_model(d, A).n",
    "d.scaled(A).n",
    "d.set_standard_dt(); d.scaled(2.0).run(A)",
    "d.show_force_chains(A)",
    "d.show_force_chains(\"f\", #{ threshold: A, slice: B })",
    "d.snapshot(A)",
    "d.snapshot_every(A, B); d.run(20)",
    "d.rolling_resistance = #{ model: \"cdt\", mu_r: A }; d.clump(d.z > B); d.run(20)",
    "d.apply_force(\"sample\", [0.0, 0.0, A]); d.clump(d.z < 0.001); d.periodic(#{ x: [-0.001, 0.004] }); d.run(B)",
];

#[test]
fn random_bad_values_give_script_errors_never_panics() {
    let dir = crate::common::temp_dir("robustness");
    let host = Rc::new(Host::new(dir));
    // A run asked for a huge number of steps does the first chunk and stops: the test is
    // about the values reaching the engine, not about running a long simulation. The flag
    // is raised only for the call: the box build of the scene stops on it too.
    let cancel = host.control.cancel.clone();
    let engine = matdem_rs::new_engine(host);
    let scene = engine.compile(SCENE).unwrap();
    // After any call, run or refused, the model's state is finite: a bad value is refused
    // before it reaches the model, and a run stops before a NaN (the guard).
    let finite = engine.compile(FINITE).unwrap();
    let run = |call: &rhai::AST| -> (Result<(), Box<rhai::EvalAltResult>>, Result<bool, Box<rhai::EvalAltResult>>) {
        cancel.store(false, Ordering::Relaxed);
        let mut scope = rhai::Scope::new();
        engine.run_ast_with_scope(&mut scope, &scene).unwrap();
        cancel.store(true, Ordering::Relaxed);
        let outcome = engine.run_ast_with_scope(&mut scope, call);
        (outcome, engine.eval_ast_with_scope::<bool>(&mut scope, &finite))
    };
    // The harness tells a refusal from success: the scene and a sound call run.
    let (outcome, state) = run(&engine.compile("d.add_group(\"g\", d.z > 0.0); zeros(3).sum()").unwrap());
    assert!(outcome.is_ok() && state.unwrap());
    // ... and the finite check sees a NaN (a check that cannot fail proves nothing). No call
    // puts one in a model (that is the point), so a map with the model's lanes stands in.
    for (value, expected) in [("1.0", true), ("(0.0/0.0)", false), ("(1.0/0.0)", false)] {
        let mut scope = rhai::Scope::new();
        let stand_in =
            format!("let f = field([1.0, {value}]); let d = #{{ x: f, y: f, z: f, vx: f, vy: f, vz: f, r: f, n: 2 }};");
        engine.run_with_scope(&mut scope, &stand_in).unwrap();
        assert_eq!(engine.eval_ast_with_scope::<bool>(&mut scope, &finite).unwrap(), expected, "{value}");
    }
    let mut runner = TestRunner::new(Config { cases: 6000, failure_persistence: None, ..Config::default() });
    let strategy = (0..CALLS.len(), 0..VALUES.len(), 0..VALUES.len());
    let (ok, errors) = (std::cell::Cell::new(0u32), std::cell::Cell::new(0u32));
    let start = std::time::Instant::now();
    let result = runner.run(&strategy, |(c, a, b)| {
        let call = CALLS[c].replace('A', VALUES[a]).replace('B', VALUES[b]);
        let ast = engine.compile(&call).map_err(|e| TestCaseError::fail(format!("{call}: {e}")))?;
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(&ast)));
        let state = match outcome {
            Ok((Ok(()), state)) => {
                ok.set(ok.get() + 1);
                state
            }
            Ok((Err(_), state)) => {
                errors.set(errors.get() + 1);
                state
            }
            Err(_) => return Err(TestCaseError::fail(format!("panic on: {call}"))),
        };
        match state {
            Ok(true) => {}
            Ok(false) => return Err(TestCaseError::fail(format!("a value in the model is not finite after: {call}"))),
            Err(e) => return Err(TestCaseError::fail(format!("the model cannot be read after: {call}: {e}"))),
        }
        Ok(())
    });
    eprintln!(
        "robustness: {} cases ({} ran, {} refused with a script error) in {:.1} s",
        ok.get() + errors.get(),
        ok.get(),
        errors.get(),
        start.elapsed().as_secs_f64()
    );
    result.unwrap();
}
