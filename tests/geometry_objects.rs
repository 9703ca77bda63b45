//! Geometry objects (MatDEM's `mfs`, issue 12 item 3): shapes made on a lattice, moved,
//! turned, combined and filtered as whole arrays before `d.add_elements(g, material, group)`;
//! an FCC lattice built through the script API with the lattice formulas' material returns
//! their E and ν along [111]; every bad input is refused by name and changes nothing.

use crate::common::{run_script, stderr, stdout, temp_dir};
use matdem_rs::api::Host;
use rhai::{Dynamic, Engine, Scope};
use std::rc::Rc;

struct Session {
    engine: Engine,
    scope: Scope<'static>,
}

impl Session {
    fn new(name: &str) -> Self {
        Session { engine: matdem_rs::new_engine(Rc::new(Host::new(temp_dir(name)))), scope: Scope::new() }
    }

    fn eval<T: Clone + 'static>(&mut self, script: &str) -> T {
        self.engine.eval_with_scope::<T>(&mut self.scope, script).unwrap_or_else(|e| panic!("script failed: {e}"))
    }

    fn refusal(&mut self, script: &str) -> String {
        match self.engine.eval_with_scope::<Dynamic>(&mut self.scope, script) {
            Ok(v) => panic!("`{script}` should be refused, gave {v}"),
            Err(e) => e.to_string(),
        }
    }
}

#[test]
fn shapes_hold_whole_elements_inside_their_outline() {
    let mut s = Session::new("geometry_shapes");
    let ok: bool = s.eval(
        "let r = 0.5e-3; \
         let b = make_box(0.01, 0.008, 0.006, r); \
         let ok1 = b.n > 0 && (b.x - r).min() >= -1e-12 && (b.x + r).max() <= 0.01 + 1e-12 \
             && (b.y + r).max() <= 0.008 + 1e-12 && (b.z + r).max() <= 0.006 + 1e-12 && (b.z - r).min() >= -1e-12; \
         let c = make_column(0.004, 0.005, r); \
         let rho = (c.x * c.x + c.y * c.y).sqrt(); \
         let ok2 = c.n > 0 && (rho + r).max() <= 0.004 + 1e-12; \
         let t = make_tube(0.002, 0.004, 0.005, r, \"hcp\"); \
         let rt = (t.x * t.x + t.y * t.y).sqrt(); \
         let ok3 = t.n > 0 && (rt - r).min() >= 0.002 - 1e-12 && (rt + r).max() <= 0.004 + 1e-12 \
             && make_ring(0.002, 0.004, 0.005, r, \"hcp\").n == t.n; \
         let s = make_sphere(0.003, r); \
         let rs = (s.x * s.x + s.y * s.y + s.z * s.z).sqrt(); \
         let ok4 = s.n > 0 && (rs + r).max() <= 0.003 + 1e-12; \
         let disc = make_disc(0.003, r); \
         let ok5 = disc.n > 0 && disc.z.abs().max() == 0.0; \
         let l = make_lattice(\"sc\", 3, 4, 5, 1e-3); \
         ok1 && ok2 && ok3 && ok4 && ok5 && l.n == 60 && l.x.max() == 2e-3 && l.z.max() == 4e-3",
    );
    assert!(ok);
}

#[test]
fn moves_turns_combinations_and_filters_are_whole_array_values() {
    let mut s = Session::new("geometry_transforms");
    let ok: bool = s.eval(
        "let g = make_lattice(\"fcc\", 4, 4, 3, 1e-3); \
         let m = g.moved(0.01, -0.02, 0.5); \
         let ok1 = (m.x - g.x - 0.01).abs().max() < 1e-15 && (m.z - g.z - 0.5).abs().max() < 1e-15 && g.x.min() == 0.0; \
         let q = g.rotated([0, 0, 1], 90.0); \
         let ok2 = (q.x + g.y).abs().max() < 1e-15 && (q.y - g.x).abs().max() < 1e-15; \
         let p = g.rotated([0, 0, 1], 180.0, [1e-3, 0.0, 0.0]); \
         let ok3 = (p.x - (2e-3 - g.x)).abs().max() < 1e-15; \
         let both = g + m; \
         let ok4 = both.n == 2 * g.n && both.x.max() == m.x.max() && combine([g, m, q]).n == 3 * g.n \
             && g.combine(m).n == both.n; \
         let low = both.filter(both.z < 0.1); \
         let ok5 = low.n == g.n && (low.z - g.z).abs().max() == 0.0 && g.copy().n == g.n; \
         let t = g.to_table(); let back = geometry(t); \
         let ok6 = back.n == g.n && (back.y - g.y).abs().max() == 0.0 && geometry(g.x, g.y, g.z, 5e-4).n == g.n; \
         let bb = g.bounds(); \
         ok1 && ok2 && ok3 && ok4 && ok5 && ok6 && bb.lo[0] == -5e-4",
    );
    assert!(ok);
}

#[test]
fn add_elements_puts_a_geometry_in_a_model_with_its_material_and_group() {
    let mut s = Session::new("geometry_add");
    let ok: bool = s.eval(
        "let d = new_model(\"build\"); \
         let m = material_micro(\"rock\", #{ kn: 2e6, ks: 8e5, mu_p: 0.3, r: 0.5e-3 }); \
         let g = make_box(0.006, 0.006, 0.004, 0.5e-3); \
         let n1 = d.add_elements(g, m, \"block\"); \
         let col = make_column(0.001, 0.004, 0.25e-3).moved(0.003, 0.003, g.bounds().hi[2]); \
         let n2 = d.add_elements(col, \"rock\", \"pile\"); \
         let bonds = d.connect(\"block\", \"pile\", 3e-4); \
         n1 == g.n && n2 == col.n && d.n == n1 + n2 && d.group(\"pile\").len() == n2 \
           && (d.z.select(d.in_group(\"pile\")) - col.z).abs().max() == 0.0 \
           && (d.r.select(d.in_group(\"block\")) - 0.5e-3).abs().max() == 0.0 && bonds > 0 \
           && d.connect(\"block\", 1e-6) > 0",
    );
    assert!(ok);
}

#[test]
fn bad_geometry_input_is_refused_by_name_and_changes_nothing() {
    let mut s = Session::new("geometry_refusals");
    let _: Dynamic = s.eval(
        "let d = new_model(\"m\"); \
         let m = material_micro(\"rock\", #{ kn: 2e6, ks: 8e5, mu_p: 0.3, r: 0.5e-3 }); \
         let g = make_lattice(\"sc\", 2, 2, 2, 1e-3); d.add_elements(g, m, \"a\");",
    );
    let cases: &[(&str, &[&str])] = &[
        ("make_box(-0.01, 0.01, 0.01, 1e-3)", &["make_box", "width", "-0.01"]),
        ("make_box(0.01, 0.01, 0.01, 0.0)", &["element radius", "> 0"]),
        ("make_box(0.01, 0.01, 0.01, 1e-3, \"bcc\")", &["unknown lattice `bcc`", "fcc"]),
        ("make_lattice(\"fcc\", 0, 2, 2, 1e-3)", &["nx", "≥ 1"]),
        ("make_lattice(\"fcc\", 2, 2, 2, -1.0)", &["diameter"]),
        ("make_lattice(\"fcc\", 100000, 100000, 100, 1e-3)", &["more than"]),
        ("make_ring(0.004, 0.0045, 0.01, 1e-3)", &["make_ring", "one element diameter"]),
        ("make_sphere(0.01, \"a\")", &["make_sphere: ball_r", "number"]),
        ("geometry([0.0, 1.0], [0.0, 1.0], [0.0, 1.0], [1e-3, -1e-3])", &["element 1", "radius -0.001"]),
        ("geometry([0.0, 1.0], [0.0], [0.0, 1.0], 1e-3)", &["same length"]),
        ("g.filter(field([1.0]) > 0.0)", &["mask has 1 entries", "8 elements"]),
        ("g.rotated([0, 0, 0], 30.0)", &["rotation axis"]),
        ("g.moved(1.0, 1.0 / 0.0, 0.0)", &["moved: dy", "finite"]),
        ("combine([g, 1])", &["item 1", "Geometry"]),
        ("d.add_elements(g, \"granite\", \"b\")", &["granite", "set_group_mat"]),
        ("d.add_elements(g, 42, \"b\")", &["material name or a material"]),
        ("let t = new_table(); t.add_row(#{ x: 0.0, y: 0.0, z: 0.0 }); geometry(t)", &["column `r`", "x, y, z, r"]),
    ];
    for (script, words) in cases {
        let e = s.refusal(script);
        for w in *words {
            assert!(e.contains(w), "`{script}`: {e:?} lacks {w:?}");
        }
        let (n, groups): (i64, rhai::Array) = (s.eval("d.n"), s.eval("d.groups"));
        assert_eq!(n, 8, "`{script}` changed the model");
        assert_eq!(groups.len(), 1, "`{script}` added a group");
    }
}

/// The lattice test of engine/tests/lattice.rs through the script API: an FCC block from
/// `make_lattice`, `material(...)` from E and ν by the lattice formulas, every touching pair
/// bonded except the top layer's in-plane bonds (the top layer is the bottom's periodic
/// image: bonded to the block by `d.connect(a, b, gap)` only), compressed along [111] by
/// 5·10⁻⁵. E is the mean force on the top layer's elements 3d from the free sides over √3/2·d²
/// per element; ν the slope of lateral displacement against position over the mid layer.
/// Tolerance as the engine test: 2 % on E, 0.02·max(ν, 0.1) on ν.
#[test]
fn make_lattice_fcc_with_the_formulas_material_returns_e_and_nu_along_111() {
    let dir = temp_dir("geometry_lattice_111");
    let script = r#"
let D = 1e-3; let N = 18; let L = 6; let STRAIN = 5e-5;
let nu = params.nu;
let mat = material("lattice", #{ E: 1e9, nu: nu, Tu: 1e9, Cu: 1e10, mu_i: 0.6, d: D, density: 2600.0 });
let g = make_lattice("fcc", N, N, L, D);
let hl = D * sqrt(2.0 / 3.0);
let height = (L - 1) * hl;
let d = new_model("lattice");
d.add_elements(g.filter(g.z < height - hl / 2.0), mat, "body");
d.add_elements(g.filter(g.z > height - hl / 2.0), mat, "top");
d.connect("body", 0.01 * D);
d.connect("body", "top", 0.01 * D);
d.group_where("bottom", d.z < hl / 2.0);
d.fix("bottom", "z");
d.fix("top", "z");
d.damping = 0.2;
let dt = d.set_standard_dt();
let steps = 1500;
d.set("vz", "top", -STRAIN * height / (steps * dt));
d.run(steps);
d.set("vz", "top", 0.0);
d.run(2500);
let x0 = d.x - d.dx; let y0 = d.y - d.dy;
let inside = |m| (x0 > m) & (x0 < N * D - m) & (y0 > m) & (y0 < N * D * sqrt(3.0) / 2.0 - m);
let top = d.in_group("top");
let strain = -d.dz.select(top).mean() / height;
let inner = top & inside.call(3.0 * D);
let E = d.fz.select(inner).sum() / (inner.count() * sqrt(3.0) / 2.0 * D * D) / strain;
let mid = (d.z - d.dz > 3.0 * hl - hl / 2.0) & (d.z - d.dz < 3.0 * hl + hl / 2.0) & inside.call(2.0 * D);
let sx = regress(x0.select(mid), d.dx.select(mid), "linear").a;
let sy = regress(y0.select(mid), d.dy.select(mid), "linear").a;
print(`E ${E} nu ${0.5 * (sx + sy) / strain} unbalanced ${d.unbalanced_ratio()}`);
report("E", E);
report("nu", 0.5 * (sx + sy) / strain);
"#;
    for nu in [0.1, 0.2] {
        let o = run_script(&dir, "lattice.rhai", script, &["--set", &format!("nu={nu}")]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = stdout(&o);
        let line = out.lines().find(|l| l.starts_with("E ")).unwrap_or_else(|| panic!("no result line in {out}"));
        let v: Vec<f64> = line.split_whitespace().filter_map(|w| w.parse().ok()).collect();
        let (e, measured_nu) = (v[0], v[1]);
        eprintln!("ν = {nu}: {line}");
        assert!((e / 1e9 - 1.0).abs() < 0.02, "ν = {nu}: E = {e:e}");
        assert!((measured_nu - nu).abs() <= 0.02 * f64::max(nu, 0.1), "ν = {nu}: measured ν = {measured_nu}");
    }
}
