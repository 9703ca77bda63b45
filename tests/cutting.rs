//! Cutting and layers (MatDEM's `Tool_Cut`, issue 12 item 4), through the CLI: a surface
//! given as scattered points of a known plane cuts away exactly the elements on one side;
//! layers between two such surfaces hold the elements field maths counts; a polygon prism
//! selects what it should; a joint at 20 % strength breaks first under tension, at 20 % of
//! the intact column's peak force; every bad input is refused by name and changes nothing.

use crate::common::{run_script, stderr, stdout, temp_dir};
use matdem_rs::api::Host;
use rhai::{Dynamic, Engine, Scope};
use std::rc::Rc;

/// A model of 0.5 mm elements filling a 10 mm cube (FCC), and the planes the tests cut with,
/// as scattered points reaching past the model (no continuation outside the hull needed).
const BLOCK: &str = r#"
let d = new_model("block");
d.add_elements(make_box(0.01, 0.01, 0.01, 0.25e-3), material_micro("rock", #{ kn: 2e6, ks: 8e5, mu_p: 0.3, r: 0.25e-3 }), "block");
let plane_a = |x, y| 0.004 + 0.21 * x - 0.13 * y;
let plane_b = |x, y| 0.0071 - 0.05 * x + 0.09 * y;
fn points_of(f) {
    let pts = [];
    for xy in [[-0.002, -0.002], [0.013, -0.001], [0.012, 0.012], [-0.001, 0.0125], [0.005, 0.004], [0.002, 0.008], [0.009, 0.006]] {
        pts.push([xy[0], xy[1], f.call(xy[0], xy[1])]);
    }
    pts
}
let side_a = d.z - (d.x * 0.21 - d.y * 0.13 + 0.004);
let side_b = d.z - (d.x * -0.05 + d.y * 0.09 + 0.0071);
"#;

fn run(name: &str, body: &str) -> String {
    let dir = temp_dir(name);
    let o = run_script(&dir, "cut.rhai", &format!("{BLOCK}\n{body}"), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    stdout(&o)
}

/// The numbers a script printed as `result a b c …`.
fn result(out: &str) -> Vec<f64> {
    let line = out.lines().find(|l| l.starts_with("result ")).unwrap_or_else(|| panic!("no result line in {out}"));
    line.split_whitespace().skip(1).map(|w| w.parse().unwrap()).collect()
}

#[test]
fn a_surface_cut_of_a_known_plane_given_as_points_keeps_exactly_the_elements_on_one_side() {
    let v = result(&run(
        "cut_plane",
        r#"
let s = cut_surface(points_of(plane_a));
let n0 = d.n; let below = (side_a <= 0.0).count(); let clearance = side_a.abs().min();
let gone = d.cut_above(s);
let kept = d.z - (d.x * 0.21 - d.y * 0.13 + 0.004);
print(`result ${n0} ${below} ${gone} ${d.n} ${kept.max()} ${clearance} ${d.above_surface(s).count()}`);
"#,
    ));
    let (n0, below, gone, n, kept_max, clearance, above_after) = (v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
    assert!(clearance > 1e-9, "an element lies on the plane ({clearance}); the test needs a clear side");
    assert!(below > 0.0 && gone > 0.0, "{v:?}");
    assert_eq!(n, below, "kept exactly the elements below the plane");
    assert_eq!(n0, gone + n);
    assert!(kept_max < 0.0 && above_after == 0.0, "{v:?}");
    // The other side, on a fresh model: cut_below keeps those above.
    let v = result(&run(
        "cut_plane_below",
        r#"
let s = cut_surface(points_of(plane_a));
let above = (side_a > 0.0).count();
let gone = d.cut_below(s);
let kept = d.z - (d.x * 0.21 - d.y * 0.13 + 0.004);
print(`result ${above} ${d.n} ${kept.min()}`);
"#,
    ));
    assert_eq!(v[0], v[1]);
    assert!(v[2] > 0.0);
}

#[test]
fn layers_between_two_surfaces_have_the_expected_counts() {
    let v = result(&run(
        "cut_layers",
        r#"
let a = cut_surface(points_of(plane_a));
let b = cut_surface(points_of(plane_b));
let top = d.z.max();
let counts = d.layers_between([0.0, a, b, top]);
let want = [((d.z >= 0.0) & (side_a < 0.0)).count(), ((side_a >= 0.0) & (side_b < 0.0)).count(),
            ((side_b >= 0.0) & (d.z <= top)).count()];
let same = counts == want && d.group("layer2").len() == want[1];
print(`result ${counts[0]} ${counts[1]} ${counts[2]} ${want[0]} ${want[1]} ${want[2]} ${if same { 1 } else { 0 }} ${d.n}`);
"#,
    ));
    assert_eq!(v[6], 1.0, "counts {:?} want {:?}", &v[0..3], &v[3..6]);
    assert!(v[0] > 0.0 && v[1] > 0.0 && v[2] > 0.0, "{v:?}");
    // The surfaces do not cross inside the block, so the layers hold every element.
    assert_eq!(v[0] + v[1] + v[2], v[7]);
}

#[test]
fn a_polygon_prism_selects_the_centres_inside_its_outline_and_heights() {
    let v = result(&run(
        "cut_polygon",
        r#"
// A right triangle x ≥ 0.002, y ≥ 0.002, x + y ≤ 0.009, between z = 0.003 and 0.006.
let m = d.in_polygon([[0.002, 0.002], [0.007, 0.002], [0.002, 0.007]], 0.003, 0.006);
let want = (d.x > 0.002) & (d.y > 0.002) & (d.x + d.y < 0.009) & (d.z >= 0.003) & (d.z <= 0.006);
// Centres on the outline may fall either way: leave them out of the comparison.
let edge = ((d.x - 0.002).abs() < 1e-9) | ((d.y - 0.002).abs() < 1e-9) | ((d.x + d.y - 0.009).abs() < 1e-9);
print(`result ${m.count()} ${(m & !edge).count()} ${(want & !edge).count()} ${(m & want & !edge).count()} ${d.in_polygon([[0.0, 0.0], [0.01, 0.0], [0.01, 0.01], [0.0, 0.01]]).count()} ${d.n}`);
"#,
    ));
    assert!(v[0] > 0.0, "{v:?}");
    assert_eq!(v[1], v[2], "inside the outline, away from its edges");
    assert_eq!(v[3], v[2], "{v:?}");
    assert_eq!(v[4], v[5], "a square around the block holds every element");
}

/// A simple cubic column of 6 × 6 × 20 bonded elements pulled apart along z (bottom layer
/// held, top layer moved up at constant speed): every vertical bond carries the column's
/// force, so a joint at 20 % strength between layers 10 and 11 must break first, all of its
/// 36 bonds and nothing else, at 20 % of the peak force of the same column without it
/// (tolerance 10 % of that ratio: the pull is dynamic).
#[test]
fn joint_bonds_at_20_percent_strength_break_first_under_tension() {
    let script = r#"
let D = 1e-3;
let d = new_model("column");
d.add_elements(make_lattice("sc", 6, 6, 20, D), material_micro("rock", #{ kn: 1e6, ks: 4e5, xb: 1e-5, fs0: 1e3, mu_p: 0.3, r: 0.5e-3 }), "column");
let bonds = d.connect("column", 1e-9);
d.group_where("bottom", d.z < 0.5 * D);
d.group_where("top", d.z > 18.5 * D);
d.fix("bottom", "z"); d.fix("top", "z");
let joint = if params.joint { d.set_joint([0.0, 0.0, 9.5 * D], [0.0, 0.0, 1.0], 0.2) } else { 0 };
d.damping = 0.1;
let dt = d.set_standard_dt();
// Slow enough that the stress wave of the start (v·√(Kn·m) per column, doubled where it
// reflects: about 1.7 N over the 36 columns) stays near 2 % of the joint's 72 N.
d.set("vz", "top", 0.02);
let peak = 0.0;
let top = d.in_group("top");
for k in 0..4000 {
    d.run(25);
    let pull = -d.fz.select(top).sum();
    if pull > peak { peak = pull; }
    if d.broken_bonds > 0 && pull < 0.01 * peak { break; }
}
let b = d.breakages();
let z0 = d.z - d.dz;
let crossing = 0;
let first_crossing = 0;
for k in 0..b.i.len() {
    let zi = z0[b.i[k].to_int()]; let zj = z0[b.j[k].to_int()];
    let across = (zi - 9.5 * D) * (zj - 9.5 * D) < 0.0;
    if across { crossing += 1; }
    if k == 0 && across { first_crossing = 1; }
}
print(`result ${bonds} ${joint} ${b.i.len()} ${crossing} ${first_crossing} ${peak}`);
"#;
    let dir = temp_dir("cut_joint");
    let out = |joint: bool| {
        let o = run_script(&dir, "joint.rhai", script, &["--set", &format!("joint={joint}")]);
        assert!(o.status.success(), "{}", stderr(&o));
        result(&stdout(&o))
    };
    let (with, without) = (out(true), out(false));
    eprintln!("with joint {with:?}, without {without:?}");
    assert_eq!(with[1], 36.0, "the joint plane crosses the 36 vertical bonds between layers 10 and 11");
    assert!(with[2] >= 36.0 && with[4] == 1.0, "the first broken bond is a joint bond: {with:?}");
    assert_eq!(with[3], 36.0, "every joint bond broke: {with:?}");
    assert_eq!(with[2], 36.0, "and nothing else: {with:?}");
    assert!(without[2] > 0.0, "the intact column breaks too: {without:?}");
    let ratio = with[5] / without[5];
    assert!((ratio - 0.2).abs() < 0.02, "peak force ratio {ratio} (with {}, without {})", with[5], without[5]);
}

struct Session {
    engine: Engine,
    scope: Scope<'static>,
}

#[test]
fn bad_cutting_input_is_refused_by_name_and_changes_nothing() {
    let mut s =
        Session { engine: matdem_rs::new_engine(Rc::new(Host::new(temp_dir("cut_refusals")))), scope: Scope::new() };
    let setup = "let d = new_model(\"m\"); \
         d.add_elements(make_lattice(\"sc\", 3, 3, 3, 1e-3), material_micro(\"rock\", #{ kn: 2e6, ks: 8e5, xb: 1e-5, fs0: 1.0, mu_p: 0.3, r: 5e-4 }), \"all3\"); \
         d.connect(\"all3\", 1e-9); \
         let s = cut_surface([[0.0, 0.0, 0.001], [0.01, 0.0, 0.001], [0.0, 0.01, 0.001]]);";
    let _: Dynamic = s.engine.eval_with_scope(&mut s.scope, setup).unwrap();
    let cases: &[(&str, &[&str])] = &[
        ("cut_surface([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])", &["at least 3 points", "got 2"]),
        ("cut_surface([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 2.0]])", &["points 1 and 2", "(x, y) = (1, 0)"]),
        ("cut_surface([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 1.0]])", &["one line in plan"]),
        ("cut_surface([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0 / 0.0]])", &["point 2", "finite"]),
        ("cut_surface([[0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])", &["point 0", "[x, y, z]"]),
        ("cut_surface([0.0, 1.0], [0.0, 1.0, 2.0], [0.0, 1.0, 2.0])", &["same length"]),
        ("d.set_joint(s, 1.5)", &["share = 1.5", "0 (break) to 1"]),
        ("d.set_joint(s, \"half\")", &["set_joint: share", "number"]),
        ("d.set_joint([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.5)", &["normal", "[0, 0, 0]"]),
        ("d.in_polygon([[0.0, 0.0], [1.0, 0.0]])", &["at least 3 vertices"]),
        ("d.in_polygon([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])", &["zero area"]),
        ("d.in_polygon([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0, 2.0]])", &["vertex 2", "[x, y]"]),
        ("d.in_polygon([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], 0.5, 0.1)", &["z0 = 0.5", "lower height first"]),
        ("d.layers_between([s, \"top\"])", &["boundary 1", "cut surface or a height"]),
        ("d.layers_between([s])", &["at least two boundaries"]),
        ("s.height([0.0, 1.0], [0.0])", &["same length"]),
    ];
    let state = |s: &mut Session| -> String {
        let v: rhai::Array =
            s.engine.eval_with_scope(&mut s.scope, "[d.n, d.bonds, d.groups.len(), d.z.sum()]").unwrap();
        format!("{v:?}")
    };
    let before = state(&mut s);
    for (script, words) in cases {
        let e = match s.engine.eval_with_scope::<Dynamic>(&mut s.scope, script) {
            Ok(v) => panic!("`{script}` should be refused, gave {v}"),
            Err(e) => e.to_string(),
        };
        for w in *words {
            assert!(e.contains(w), "`{script}`: {e:?} lacks {w:?}");
        }
        assert_eq!(state(&mut s), before, "`{script}` changed the model");
    }
}
