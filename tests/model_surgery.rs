//! MatDEM's step 2 from scripts (issue 12): writable whole arrays, elements in and out,
//! regions, plane cuts and layers — each refusal names the bad element and changes nothing;
//! deletes keep groups, rows and bonds consistent; writes replay on resume; a GPU model
//! takes writes between runs.

use crate::common::{bin, gpu_required, run_script, stderr, stdout, temp_dir, SMALL_BOX};
use matdem_engine::physics::contact_law::PairState;
use matdem_rs::api::model::ModelHandle;
use matdem_rs::api::Host;
use rhai::{Dynamic, Engine, Scope};
use std::collections::BTreeSet;
use std::rc::Rc;

/// An engine with a scope that keeps the script's variables between evaluations.
struct Session {
    engine: Engine,
    scope: Scope<'static>,
}

impl Session {
    fn new(name: &str, setup: &str) -> Self {
        let host = Rc::new(Host::new(temp_dir(name)));
        let mut s = Session { engine: matdem_rs::new_engine(host), scope: Scope::new() };
        let _: Dynamic = s.eval(setup);
        s
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

    fn d(&self) -> ModelHandle {
        self.scope.get_value::<ModelHandle>("d").expect("the script defines `d`")
    }

    /// Everything a write could touch, for "nothing changed" checks.
    fn state(&self) -> String {
        let d = self.d();
        let data = d.data();
        let p = &data.sim.model.particles;
        let ang = p.rotation.as_ref().map(|r| format!("{:?}", r.ang_vel)).unwrap_or_default();
        format!(
            "{:?}|{:?}|{:?}|{:?}|{:?}|{ang}|{}",
            p.pos, p.radius, p.vel, p.mass, p.fixed, data.sim.model.contacts.stale
        )
    }
}

const LANES: [&str; 10] = ["x", "y", "z", "vx", "vy", "vz", "wx", "wy", "wz", "r"];

#[test]
fn each_writable_lane_round_trips_whole_and_by_selection() {
    let mut s = Session::new("surgery_round_trip", &format!("{SMALL_BOX} d.enable(\"rotation\");"));
    for lane in LANES {
        // Whole lane: a field of d.n values comes back exactly.
        let same: bool = s.eval(&format!(
            "let want = d.{lane} * 0.5 + 1e-4; d.{lane} = want; let got = d.{lane}; \
             (got - want).abs().max() == 0.0"
        ));
        assert!(same, "d.{lane} = field does not read back");
        // By ids: only those change; a field of the selection's length, then a number on an
        // empty selection.
        let ok: bool = s.eval(&format!(
            "let before = d.{lane}; d.set(\"{lane}\", [1, 4], field([2e-4, 3e-4])); let after = d.{lane}; \
             let others = where(d.x > -1e9, 1.0, 0.0).to_array(); others[1] = 0.0; others[4] = 0.0; \
             let ok1 = after[1] == 2e-4 && after[4] == 3e-4 \
                 && ((after - before) * field(others)).abs().max() == 0.0; \
             d.set(\"{lane}\", d.in_group(\"sample\") & (d.z > 1e9), 5.0); \
             ok1 && (d.{lane} - after).abs().max() == 0.0"
        ));
        assert!(ok, "d.set(\"{lane}\", ids, …) does not write exactly the selection");
        // A mask with a field of d.n values takes the selected values.
        let ok: bool = s.eval(&format!(
            "let full = d.{lane} * 0.0 + 7e-4; let sel = d.z < d.z.mean(); let before = d.{lane}; \
             d.set(\"{lane}\", sel, full); let after = d.{lane}; \
             (after.select(sel) - 7e-4).abs().max() == 0.0 && (after - before).select(!sel).abs().max() == 0.0"
        ));
        assert!(ok, "d.set(\"{lane}\", mask, field of d.n) is wrong");
    }
}

#[test]
fn bad_lane_writes_are_refused_by_index_and_change_nothing() {
    let mut s = Session::new("surgery_refusals", &format!("{SMALL_BOX} d.enable(\"rotation\");"));
    for lane in LANES {
        let before = s.state();
        let e = s.refusal(&format!("d.{lane} = field([1.0, 2.0])"));
        assert!(e.contains("2 values but the model has") && e.contains("nothing was changed"), "{lane}: {e}");
        let e = s.refusal(&format!("let a = (d.{lane} + 1e-3).to_array(); a[7] = 0.0 / 0.0; d.{lane} = field(a)"));
        assert!(
            e.contains("particle 7 (value 7)") && e.contains("NaN") && e.contains("nothing was changed"),
            "{lane}: {e}"
        );
        let e = s.refusal(&format!("d.{lane} = 1.0 / 0.0"));
        assert!(e.contains("particle 0") && e.contains("inf"), "{lane}: {e}");
        let e = s.refusal(&format!("d.set(\"{lane}\", [2, 5, 9], field([1e-3, 0.0 / 0.0, 1e-3]))"));
        assert!(e.contains("particle 5 (value 1)") && e.contains("NaN"), "{lane}: {e}");
        let e = s.refusal(&format!("d.set(\"{lane}\", [2, 5], field([1e-3, 1e-3, 1e-3]))"));
        assert!(e.contains("3 values, but the selection has 2"), "{lane}: {e}");
        let e = s.refusal(&format!("d.set(\"{lane}\", [2, 5000], 1e-3)"));
        assert!(e.contains("5000"), "{lane}: {e}");
        assert_eq!(before, s.state(), "a refused write of `{lane}` changed the model");
    }
    let before = s.state();
    for bad in ["0.0", "-1e-4"] {
        let e = s.refusal(&format!("d.set(\"r\", [3, 11], field([2e-4, {bad}]))"));
        assert!(e.contains("particle 11 (value 1)") && e.contains("> 0 m"), "{e}");
    }
    let e = s.refusal("d.set(\"q\", [1], 1.0)");
    assert!(e.contains("not a writable lane") && e.contains("vx"), "{e}");
    assert_eq!(before, s.state(), "a refused radius write changed the model");
}

#[test]
fn angular_lanes_need_rotation_and_rotation_can_be_fixed() {
    let mut s = Session::new("surgery_rotation", SMALL_BOX);
    let before = s.state();
    for call in ["d.wx", "d.wz = 1.0", "d.set(\"wy\", [0], 1.0)"] {
        let e = s.refusal(call);
        assert!(e.contains("rotation is off") && e.contains("d.enable(\"rotation\")"), "{call}: {e}");
    }
    for dofs in ["r", "xr", "rq", "xw"] {
        let e = s.refusal(&format!("d.fix(\"sample\", \"{dofs}\")"));
        assert!(e.contains("rx") && e.contains(&format!("\"{dofs}\"")), "{e}");
    }
    assert_eq!(before, s.state());
    let n: i64 = s.eval("d.enable(\"rotation\"); d.wz = 2.0; d.run(10); d.wz.len()");
    assert!(n > 0);
    // Fixed about z (and x, y in the same call's letters), a spin keeps its value through the
    // contacts' torques; freed, it changes again.
    let lo: f64 = s.eval("d.fix(\"sample\", \"rz, rxry\"); d.wz = 2.0; d.wx = 0.5; d.run(50); d.wz.min() + d.wx.min()");
    let hi: f64 = s.eval("d.wz.max() + d.wx.max()");
    assert_eq!((lo, hi), (2.5, 2.5));
}

#[test]
fn a_radius_write_scales_mass_by_the_cube_and_inertia_follows() {
    let mut s = Session::new("surgery_radius", SMALL_BOX);
    let (m0, i0): (Vec<f64>, Vec<f64>) = {
        let d = s.d();
        let data = d.data();
        let p = &data.sim.model.particles;
        (p.mass.clone(), (0..p.len()).map(|i| p.inertia(i)).collect())
    };
    s.eval::<()>("let scale = where(d.x > 0.002, 1.25, 0.8); d.r = d.r * scale;");
    let d = s.d();
    let data = d.data();
    let p = &data.sim.model.particles;
    assert!(data.sim.model.contacts.stale, "a radius write must make the rows stale");
    for i in 0..p.len() {
        let k: f64 = if p.pos[i].x > 0.002 { 1.25 } else { 0.8 };
        assert!((p.mass[i] / m0[i] - k.powi(3)).abs() < 1e-12, "mass of {i}");
        assert!((p.inertia(i) / i0[i] - k.powi(5)).abs() < 1e-12, "inertia of {i}");
    }
}

/// The state of every pair (i, j) as seen from row i.
fn pair_states(d: &ModelHandle) -> std::collections::BTreeMap<(u32, u32), PairState> {
    let data = d.data();
    let c = &data.sim.model.contacts;
    let mut out = std::collections::BTreeMap::new();
    for i in 0..c.row_start.len().saturating_sub(1) {
        for e in c.row(i) {
            out.insert((i as u32, c.other[e]), c.state[e]);
        }
    }
    out
}

/// Bonded pairs (i < j) of the model.
fn bonds(d: &ModelHandle) -> BTreeSet<(u32, u32)> {
    let data = d.data();
    let c = &data.sim.model.contacts;
    let mut out = BTreeSet::new();
    for i in 0..c.row_start.len().saturating_sub(1) {
        for e in c.row(i) {
            if c.state[e].bonded && (i as u32) < c.other[e] {
                out.insert((i as u32, c.other[e]));
            }
        }
    }
    out
}

#[test]
fn delete_keeps_groups_rows_and_the_bonds_among_survivors() {
    let mut s = Session::new(
        "surgery_delete",
        &format!(
            "{SMALL_BOX} d.gravity = [0.0, 0.0, -9.81]; d.local_damping = 0.5; d.balance(1500); \
             d.set_group_mat(\"sample\", material_micro(\"rock\", #{{ kn: 2e5, ks: 8e4, xb: 1e-4, fs0: 5.0, mu_p: 0.3, r: 0.4e-3, restitution: 0.3 }})); \
             let made = d.connect(\"all\", 2e-5); d.gravity = [0.3, 0.0, -9.81]; d.run(50); d.add_group(\"low\", d.z < 0.0012);"
        ),
    );
    let made: i64 = s.eval("made");
    let before = bonds(&s.d());
    assert!(made > 20 && before.len() as i64 == made, "{made} bonds made, {} found", before.len());
    let states = pair_states(&s.d());
    let doomed: Vec<bool> = s
        .eval::<matdem_rs::api::arrays::Mask>("let doomed = d.in_sphere(0.002, 0.002, 0.001, 0.0012); doomed")
        .0
        .to_vec();
    let low: Vec<i64> = s.eval::<rhai::Array>("d.group(\"low\")").into_iter().map(|v| v.as_int().unwrap()).collect();
    let n0 = doomed.len();
    assert!(doomed.iter().any(|&b| b) && !doomed.iter().all(|&b| b));
    let deleted: i64 = s.eval("d.delete(doomed)");
    assert_eq!(deleted as usize, doomed.iter().filter(|&&b| b).count());

    // Old id → new id: survivors keep their order.
    let mut map = vec![None; n0];
    let mut next = 0u32;
    for (i, &gone) in doomed.iter().enumerate() {
        if !gone {
            map[i] = Some(next);
            next += 1;
        }
    }
    let want: BTreeSet<(u32, u32)> =
        before.iter().filter_map(|&(i, j)| Some((map[i as usize]?, map[j as usize]?))).collect();
    assert!(want.len() < before.len(), "the cut must cross some bonds");
    let d = s.d();
    assert_eq!(bonds(&d), want, "exactly the bonds whose both ends survived remain");
    // Every pair between survivors keeps its state: bond, shear spring, dashpot.
    let after = pair_states(&d);
    let (mut carried, mut sheared) = (0, 0);
    for (&(i, j), st) in &states {
        if let (Some(a), Some(b)) = (map[i as usize], map[j as usize]) {
            assert_eq!(after.get(&(a, b)), Some(st), "pair ({i}, {j}) → ({a}, {b}) lost its state");
            carried += 1;
            sheared += usize::from(st.shear.norm() > 0.0);
        }
    }
    assert!(carried > 100 && sheared > 0, "{carried} pairs carried, {sheared} with a shear spring");
    let count: i64 = s.eval("d.bonds");
    assert_eq!(count as usize, want.len());
    {
        let data = d.data();
        let m = &data.sim.model;
        let c = &m.contacts;
        assert_eq!(m.len(), n0 - deleted as usize);
        assert_eq!(c.row_start.len(), m.len() + 1, "rows match the survivors");
        for i in 0..m.len() {
            for e in c.row(i) {
                let j = c.other[e] as usize;
                assert!(j < m.len() && j != i, "row {i} names {j}");
                let back = c.find(j, i as u32).expect("pairs are in both rows");
                assert_eq!(c.state[back].bonded, c.state[e].bonded, "both halves of ({i}, {j}) agree");
            }
        }
        assert_eq!(m.wall_contacts.len(), m.len() * m.walls.len());
    }
    let low_after: Vec<i64> =
        s.eval::<rhai::Array>("d.group(\"low\")").into_iter().map(|v| v.as_int().unwrap()).collect();
    let low_want: Vec<i64> = low.iter().filter_map(|&i| map[i as usize].map(|k| k as i64)).collect();
    assert_eq!(low_after, low_want, "groups are renumbered, the deleted left out");
    // The cut model runs on; every bond is either intact or booked as broken.
    let (intact, broken): (i64, i64) = {
        let r: rhai::Array = s.eval("d.run(300); [d.bonds, d.broken_bonds]");
        (r[0].as_int().unwrap(), r[1].as_int().unwrap())
    };
    assert_eq!((intact + broken) as usize, want.len(), "bonds after the cut are kept or broken, none lost");
}

#[test]
fn a_plane_cut_keeps_exactly_the_elements_on_one_side() {
    let mut s = Session::new("surgery_plane", SMALL_BOX);
    let r: rhai::Array = s.eval(
        "let p = [0.002, 0.002, 0.0015]; let nrm = [1.0, 0.5, 2.0]; \
         let side = (d.x - 0.002) * 1.0 + (d.y - 0.002) * 0.5 + (d.z - 0.0015) * 2.0; \
         let keep = (side <= 0.0).count(); let n0 = d.n; \
         let gone = d.delete(d.above_plane(p, nrm)); \
         let side2 = (d.x - 0.002) * 1.0 + (d.y - 0.002) * 0.5 + (d.z - 0.0015) * 2.0; \
         [n0, gone, keep, d.n, side2.max(), d.above_plane(p, nrm).count()]",
    );
    let v: Vec<f64> = r.iter().map(|x| x.as_float().unwrap_or_else(|_| x.as_int().unwrap() as f64)).collect();
    assert!(v[1] > 0.0 && v[2] > 0.0, "{v:?}");
    assert_eq!(v[3], v[2], "kept exactly the elements below the plane: {v:?}");
    assert_eq!(v[0], v[1] + v[2]);
    assert!(v[4] <= 0.0 && v[5] == 0.0, "{v:?}");
}

#[test]
fn regions_are_masks_that_combine_and_feed_groups() {
    let mut s = Session::new("surgery_regions", SMALL_BOX);
    let ok: bool = s.eval(
        "let a = d.in_box(0.0, 0.002, 0, 0.004, 0, 1.0); \
         let ok1 = a.count() == (d.x <= 0.002).count(); \
         let c = d.in_cylinder(0.002, 0.002, 0.001, 0.0, 0.0015); \
         let rr = (d.x - 0.002) * (d.x - 0.002) + (d.y - 0.002) * (d.y - 0.002); \
         let ok2 = c.count() == ((rr <= 1e-6) & (d.z <= 0.0015)).count(); \
         let sp = d.in_sphere(0.002, 0.002, 0.0015, 0.001); \
         let ok3 = sp.count() == (rr + (d.z - 0.0015) * (d.z - 0.0015) <= 1e-6).count(); \
         let n = d.add_group(\"core\", sp & !a); \
         ok1 && ok2 && ok3 && n == (sp & !a).count() && n > 0",
    );
    assert!(ok);
    for (call, want) in [
        ("d.in_box(0.003, 0.002, 0, 1, 0, 1)", "inverted along x"),
        ("d.in_sphere(0, 0, 0, -1)", "must be a finite number > 0"),
        ("d.in_cylinder(0, 0, 1, 2, 1)", "z0 ≤ z1"),
        ("d.above_plane([0, 0, 0], [0, 0, 0])", "must not be [0, 0, 0]"),
        ("d.in_box(0, 1, 0, 1, 0, \"top\")", "must be a number"),
        ("d.layers_between([0.002, 0.001])", "increasing order"),
        ("d.layers_between([0.002])", "at least two planes"),
    ] {
        let e = s.refusal(call);
        assert!(e.contains(want), "{call}: {e}");
    }
}

#[test]
fn layers_between_planes_have_the_expected_counts() {
    let mut s = Session::new("surgery_layers", SMALL_BOX);
    let ok: bool = s.eval(
        "let top = d.z.max(); let counts = d.layers_between([0.0, 0.001, 0.002, top]); \
         let want = [((d.z >= 0.0) & (d.z < 0.001)).count(), ((d.z >= 0.001) & (d.z < 0.002)).count(), \
                     ((d.z >= 0.002) & (d.z <= top)).count()]; \
         counts == want && d.group(\"layer2\").len() == want[1] && counts[0] > 0 && counts[2] > 0 \
           && counts[0] + counts[1] + counts[2] == d.n",
    );
    assert!(ok, "horizontal layers");
    // Inclined planes through points, in order along the normal.
    let ok: bool = s.eval(
        "let counts = d.layers_between([[0.0, 0.0, 0.0], [0.002, 0.0, 0.0]], [1.0, 0.0, 1.0]); \
         let t = (d.x + d.z) / sqrt(2.0); let s1 = 0.002 / sqrt(2.0); \
         counts == [((t >= 0.0) & (t <= s1)).count()] && d.group(\"layer1\").len() == counts[0]",
    );
    assert!(ok, "inclined layers");
}

#[test]
fn keep_groups_move_group_freeze_and_unfreeze() {
    let mut s = Session::new("surgery_groups", SMALL_BOX);
    let ok: bool = s.eval(
        "let c = d.layers_between([0.0, 0.001, 0.002, d.z.max()]); \
         let gone = d.keep_groups([\"layer1\", \"layer2\"]); \
         d.n == c[0] + c[1] && gone == c[2] && d.group(\"layer3\").len() == 0",
    );
    assert!(ok, "keep_groups");
    let ok: bool = s.eval(
        "let x0 = d.x; let z0 = d.z; let m = d.in_group(\"layer2\"); \
         d.move_group(\"layer2\", 1e-4, 0, -2e-5); \
         ((d.x - x0).select(m) / 1e-4 - 1.0).abs().max() < 1e-9 && (d.x - x0).select(!m).abs().max() == 0.0 \
           && ((d.z - z0).select(m) / -2e-5 - 1.0).abs().max() < 1e-9",
    );
    assert!(ok, "move_group");
    let ok: bool = s.eval(
        "d.gravity = [0.0, 0.0, -9.81]; d.set(\"vz\", \"layer1\", -0.1); let f = d.freeze(\"layer1\"); \
         let m = d.in_group(\"layer1\"); let z0 = d.z; d.run(200); \
         let still = (d.z - z0).select(m).abs().max() == 0.0 && d.vz.select(m).abs().max() == 0.0; \
         d.unfreeze(\"layer1\"); d.run(200); \
         still && f == m.count() && (d.z - z0).select(m).abs().max() > 0.0",
    );
    assert!(ok, "freeze holds a group still, unfreeze lets it go");
    for (call, want) in [
        ("d.keep_groups([])", "name at least one group"),
        ("d.keep_groups([\"layr1\"])", "layer1"),
        ("d.move_group(\"layer1\", 0.0 / 0.0, 0, 0)", "finite"),
        ("d.delete([0, 99999])", "99999"),
    ] {
        let before = s.state();
        let e = s.refusal(call);
        assert!(e.contains(want), "{call}: {e}");
        assert_eq!(before, s.state(), "{call} changed the model");
    }
}

#[test]
fn add_elements_from_a_csv_adds_the_rows_and_refuses_a_bad_row_whole() {
    let dir = temp_dir("surgery_add");
    std::fs::write(
        dir.join("new.csv"),
        "x,y,z,r\n0.001,0.001,0.0045,2e-4\n0.002,0.002,0.0045,3e-4\n0.003,0.003,0.0045,2.5e-4\n",
    )
    .unwrap();
    std::fs::write(dir.join("bad.csv"), "x,y,z,r\n0.001,0.001,0.005,2e-4\n0.002,0.002,0.005,-3e-4\n").unwrap();
    std::fs::write(dir.join("short.csv"), "x,y,z\n0.001,0.001,0.005\n").unwrap();
    let script = format!(
        r#"{SMALL_BOX}
        let n0 = d.n;
        let t = load_table("new.csv");
        let added = d.add_elements(t, "m", "lid");
        let ids = d.group("lid");
        let last = d.n - 1;
        print(`added=${{added}} grew=${{d.n - n0}} ids=${{ids}} n0=${{n0}}`);
        print(`z=${{fmt(d.z[last], 6)}} r=${{fmt(d.r[last], 6)}} mass_ratio=${{fmt(d.mass[last] / d.mass[0] * (d.r[0] ** 3) / (2.5e-4 ** 3), 9)}} end`);
        let n1 = d.n;
        try {{ d.add_elements(load_table("bad.csv"), "m", "lid"); }} catch (e) {{ print(`bad: ${{e}}`); }}
        try {{ d.add_elements(load_table("short.csv"), "m", "lid"); }} catch (e) {{ print(`short: ${{e}}`); }}
        try {{ d.add_elements(t, "granite", "lid"); }} catch (e) {{ print(`material: ${{e}}`); }}
        print(`unchanged=${{d.n == n1 && d.group("lid").len() == 3}}`);
        d.gravity = [0.0, 0.0, -9.81];
        d.run(200);
        print(`moved=${{(d.z.select(d.in_group("lid")) - 0.0045).abs().min() > 0.0}}`);
        "#
    );
    let o = run_script(&dir, "add.rhai", &script, &[]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}\n{out}", stderr(&o));
    let n0: usize = out.split("n0=").nth(1).unwrap().trim().lines().next().unwrap().parse().unwrap();
    assert!(out.contains("added=3 grew=3"), "{out}");
    assert!(out.contains(&format!("ids=[{}, {}, {}]", n0, n0 + 1, n0 + 2)), "{out}");
    assert!(out.contains("z=0.004500 r=0.000250"), "{out}");
    let ratio: f64 = out.split("mass_ratio=").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!((ratio - 1.0).abs() < 1e-9, "mass follows the material's density: {out}");
    assert!(
        out.contains("bad: add_elements: table row 1")
            && out.contains("r = -0.0003")
            && out.contains("nothing was added"),
        "{out}"
    );
    assert!(out.contains("short: add_elements: no column `r`"), "{out}");
    assert!(out.contains("material: add_elements: unknown material"), "{out}");
    assert!(out.contains("unchanged=true") && out.contains("moved=true"), "{out}");
}

/// Surgery before, between and after the interrupted stage: the resumed run repeats the
/// writes while replaying and ends with the uninterrupted run's outputs, bit for bit.
#[test]
fn surgery_replays_on_resume_bit_for_bit() {
    let dir = temp_dir("surgery_resume");
    std::fs::write(dir.join("lid.csv"), "x,y,z,r\n0.002,0.002,0.0075,4e-4\n0.004,0.004,0.0075,4e-4\n").unwrap();
    let script = r#"
let b = new_box("tiny");
b.ball_r = 0.5e-3; b.distri_rate = 0.2;
b.sample_w = 6e-3; b.sample_l = 6e-3; b.sample_h = 8e-3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, r: 0.5e-3, mu_p: 0.5, restitution: 0.5 }));
d.set_standard_dt();
d.gravity = [0.0, 0.0, -9.81 * 50.0];
d.local_damping = 0.3;
d.delete(d.in_sphere(0.003, 0.003, 0.004, 0.001));
d.r = d.r * 0.98;
for k in 0..6 {
    d.run(2500);
    d.record(#{ stage: k, mean_z: d.z.mean(), n: d.n });
    d.status.save("progress.csv");
    if k == 0 {
        d.layers_between([0.0, 0.002, 0.004, 0.01]);
        d.set("vz", "layer3", -0.01);
        d.move_group("layer2", 0.0, 0.0, 1e-5);
        d.add_elements(load_table("lid.csv"), "grain", "lid");
        d.freeze("layer1");
    }
    if k == 3 { d.keep_groups(["layer1", "layer2", "lid"]); d.unfreeze("layer1"); }
}
d.status.save("final.csv");
d.save("settled");
"#;
    let path = dir.join("tiny.rhai");
    std::fs::write(&path, script).unwrap();
    let straight = bin().arg("run").arg(&path).arg("--out").arg(dir.join("straight")).output().unwrap();
    assert!(straight.status.success(), "{}", stderr(&straight));

    let out = dir.join("cut");
    let mut child =
        bin().arg("run").arg(&path).arg("--out").arg(&out).stdout(std::process::Stdio::null()).spawn().unwrap();
    let start = std::time::Instant::now();
    while !out.join("progress.csv").exists() {
        assert!(start.elapsed() < std::time::Duration::from_secs(60), "the run never wrote its first table");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    std::process::Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "interrupted");
    assert!(!out.join("final.csv").exists(), "the interruption must land before the end of the run");
    let resumed = bin().arg("run").arg(&path).arg("--resume").arg(&out).output().unwrap();
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    for file in ["final.csv", "progress.csv", "settled.mdem"] {
        let (a, b) = (std::fs::read(dir.join("straight").join(file)).unwrap(), std::fs::read(out.join(file)).unwrap());
        assert!(a == b, "{file} of the resumed run differs from the uninterrupted run's");
    }
}

/// On the GPU backend the host model is the truth between runs: writes, deletes and
/// additions made there are what the next run uploads, and it agrees with the CPU run.
#[test]
fn writes_between_gpu_runs_are_what_the_next_run_steps() {
    let dir = temp_dir("surgery_gpu");
    std::fs::write(dir.join("lid.csv"), "x,y,z,r\n0.002,0.002,0.0035,3e-4\n").unwrap();
    let script = format!(
        r#"{SMALL_BOX}
        d.gravity = [0.0, 0.0, -9.81];
        d.run(200);
        d.delete(d.in_sphere(0.002, 0.002, 0.001, 0.0008));
        d.r = d.r * 0.95;
        d.set("vz", d.z > 0.0015, -0.05);
        d.x = d.x + 1e-5;
        d.add_elements(load_table("lid.csv"), "m", "lid");
        d.run(300);
        print(`n=${{d.n}} zsum=${{fmt(d.z.sum(), 9)}} lid=${{fmt(d.z.select(d.in_group("lid")).sum(), 9)}} mass=${{fmt(d.mass.sum() * 1e6, 9)}}`);
        "#
    );
    let mut lines = Vec::new();
    for backend in ["cpu", "gpu"] {
        let o = run_script(&dir, "gpu.rhai", &script, &["--backend", backend]);
        if backend == "gpu" && o.status.code() == Some(2) && !gpu_required() {
            eprintln!("skipped: no GPU adapter");
            return;
        }
        assert!(o.status.success(), "{backend}: {}", stderr(&o));
        let line = stdout(&o).lines().find(|l| l.starts_with("n=")).unwrap().to_string();
        lines.push(line);
    }
    let num = |l: &str, key: &str| -> f64 { l.split(key).nth(1).unwrap().split(' ').next().unwrap().parse().unwrap() };
    let (cpu, gpu) = (&lines[0], &lines[1]);
    assert_eq!(num(cpu, "n="), num(gpu, "n="), "{cpu} / {gpu}");
    assert!((num(cpu, "mass=") - num(gpu, "mass=")).abs() <= 1e-6 * num(cpu, "mass="), "{cpu} / {gpu}");
    for key in ["zsum=", "lid="] {
        let (a, b) = (num(cpu, key), num(gpu, key));
        assert!((a - b).abs() <= 2e-3 * a.abs(), "{key} cpu {a} vs gpu {b}");
    }
}

// ---- Per-element micro values (MatDEM d.mo.aKN …) and killElement -----------------------

const MICRO: [&str; 5] = ["kn", "ks", "xb", "fs0", "mu_p"];

/// The materials and each element's material index, for "nothing changed" checks.
fn materials_state(s: &Session) -> String {
    let d = s.d();
    let data = d.data();
    let m = &data.sim.model;
    format!("{:?}|{:?}", m.materials, m.particles.material)
}

#[test]
fn each_micro_lane_round_trips_whole_and_by_selection_and_clones_only_what_it_must() {
    let mut s = Session::new("surgery_micro_round_trip", SMALL_BOX);
    let n: i64 = s.eval("d.n");
    for lane in MICRO {
        // By ids: exactly those two change, to exactly the values given.
        let ok: bool = s.eval(&format!(
            "let before = d.{lane}; d.set(\"{lane}\", [1, 4], field([0.25, 0.5])); let after = d.{lane}; \
             let others = where(d.x > -1e9, 1.0, 0.0).to_array(); others[1] = 0.0; others[4] = 0.0; \
             after[1] == 0.25 && after[4] == 0.5 && ((after - before) * field(others)).abs().max() == 0.0"
        ));
        assert!(ok, "d.set(\"{lane}\", ids, …) does not write exactly the selection");
        // Whole: a distinct value per element comes back exactly (one clone per element).
        let same: bool =
            s.eval(&format!("let want = d.x * 1e3 + 0.125; d.{lane} = want; (d.{lane} - want).abs().max() == 0.0"));
        assert!(same, "d.{lane} = field does not read back");
    }
    // Clones no element uses any more were dropped: every clone (`m~k`) has elements.
    let unused_clones = |s: &Session| {
        let d = s.d();
        let data = d.data();
        let m = &data.sim.model;
        (0..m.materials.len())
            .filter(|&k| m.materials[k].name.contains('~') && !m.particles.material.contains(&(k as u32)))
            .count()
    };
    let nmat = s.d().data().sim.model.materials.len() as i64;
    assert!(nmat > n / 2, "{nmat} materials for {n} distinct values");
    assert_eq!(unused_clones(&s), 0);
    // One value for a group: its elements share one clone, the others keep theirs.
    let shared: f64 = s.eval(
        "d.set(\"kn\", \"sample\", 3e5); d.set(\"ks\", \"sample\", 1e5); d.set(\"xb\", \"sample\", 0.0); \
         d.set(\"fs0\", \"sample\", 0.0); d.set(\"mu_p\", \"sample\", 0.3); \
         d.material.select(d.in_group(\"sample\")).max() - d.material.select(d.in_group(\"sample\")).min()",
    );
    assert_eq!(shared, 0.0, "one value for a whole group is one material");
    let names: Vec<String> = s.d().data().sim.model.materials.iter().map(|m| m.name.clone()).collect();
    assert!(names.iter().any(|m| m == "m") && names.iter().filter(|m| m.contains('~')).count() == 1, "{names:?}");
    assert_eq!(unused_clones(&s), 0);
    // A value set on elements steps: the plan's pair table is rebuilt with it.
    let _: Dynamic = s.eval("d.run(5); 0");
}

#[test]
fn bad_micro_writes_are_refused_by_index_and_change_nothing() {
    let mut s = Session::new("surgery_micro_refusals", SMALL_BOX);
    let _: Dynamic = s.eval("d.set(\"kn\", [2], 4e5); 0");
    let before = materials_state(&s);
    let cases = [
        ("d.set(\"kn\", [0, 3], field([1.0, 2.0, 3.0]))", "3 values"),
        ("d.kn = field([1.0, 2.0])", "the field has 2 values"),
        ("d.set(\"kn\", [0, 3], field([1e5, 0.0]))", "particle 3 (value 1)"),
        ("d.set(\"kn\", [0, 5], field([1e5, -1.0]))", "particle 5 (value 1)"),
        ("d.set(\"ks\", [7], -1.0)", "particle 7 (value 0)"),
        ("d.set(\"xb\", [1, 2, 6], field([1e-6, 2e-6, 1.0 / 0.0]))", "particle 6 (value 2)"),
        ("d.set(\"fs0\", [3], 0.0 / 0.0)", "particle 3 (value 0)"),
        ("d.set(\"mu_p\", [4], -0.1)", "particle 4 (value 0)"),
        ("d.set(\"kx\", [4], 1.0)", "`kx` is not a writable lane"),
        ("d.set(\"kn\", [99999], 1.0)", "99999"),
    ];
    for (script, want) in cases {
        let e = s.refusal(script);
        assert!(e.contains(want), "`{script}`: {e}");
        let lane = script.split('"').nth(1).unwrap_or("kn");
        assert!(e.contains(lane) || script.contains("99999"), "`{script}` names the value: {e}");
        assert_eq!(materials_state(&s), before, "`{script}` changed the model");
    }
    // Too many distinct values: refused with the advice to bin them, nothing changed.
    let mut big = Session::new(
        "surgery_micro_limit",
        r#"let d = new_model("big");
           d.add_elements(make_box(0.004, 0.004, 0.004, 0.25e-3), material_micro("rock", #{ kn: 1e6, ks: 4e5, mu_p: 0.3, r: 0.25e-3 }), "rock");"#,
    );
    let n: i64 = big.eval("d.n");
    assert!(n > 256, "{n} elements: the limit test needs more than 256");
    let before = materials_state(&big);
    let e = big.refusal("d.kn = d.x * 1e8 + d.y * 1e6 + d.z * 1e4 + 1e5");
    assert!(e.contains("at most 256") && e.contains("bin the values") && e.contains("nothing was changed"), "{e}");
    assert_eq!(materials_state(&big), before);
    // Binned into 32 classes it goes through.
    let classes: i64 = big.eval(
        "let v = d.x * 1e8 + 1e5; let step = (v.max() - v.min()) / 31.0; \
         d.kn = ((v - v.min()) / step).round() * step + v.min(); d.material.max().to_int() + 1",
    );
    assert!(classes <= 33, "{classes} materials after binning into 32 classes");
}

#[test]
fn micro_values_survive_a_checkpoint() {
    let dir = temp_dir("surgery_micro_checkpoint");
    let save = format!(
        r#"{SMALL_BOX}
        d.kn = d.x * 1e7 + 1e5;
        d.set("xb", d.z > 0.0015, 2e-6);
        d.set("mu_p", [0, 1, 2], field([0.1, 0.2, 0.4]));
        d.save("micro");
        print(`before ${{fmt(d.kn.sum(), 12)}} ${{fmt(d.xb.sum() * 1e6, 12)}} ${{fmt(d.mu_p.sum(), 12)}}`);
        "#
    );
    let o = run_script(&dir, "save.rhai", &save, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let load = r#"let d = load_model("micro");
        print(`after ${fmt(d.kn.sum(), 12)} ${fmt(d.xb.sum() * 1e6, 12)} ${fmt(d.mu_p.sum(), 12)}`);"#;
    let o2 = run_script(&dir, "load.rhai", load, &[]);
    assert!(o2.status.success(), "{}", stderr(&o2));
    let line = |o: &std::process::Output, key: &str| {
        stdout(o).lines().find(|l| l.starts_with(key)).unwrap().split_once(' ').unwrap().1.to_string()
    };
    assert_eq!(line(&o, "before"), line(&o2, "after"));
}

/// A vertical chain of 10 bonded elements (r = 0.5 mm, ρ = 2650) on a fixed bottom element,
/// each held in x and y, under gravity 1000 m/s² with viscous damping, run to rest. Contact c
/// (between elements c − 1 and c) carries the weight above it, (10 − c)·m·g, and shortens by
/// that over its spring; with the upper half set to Kn = 4e4 N/m on 1e4 the springs are 1e4
/// below, 2·(2e4·8e4)/(2e4 + 8e4)/2 = 1.6e4 at the interface (the element springs 2·Kn in
/// series) and 4e4 above. The top's settlement matches Σ F_c/k_c within 1e-6 for both the
/// uniform and the two-material column.
#[test]
fn a_stiffer_layer_shortens_as_springs_in_series() {
    let settle = |upper_kn: Option<f64>| -> (f64, f64) {
        let set = upper_kn.map(|k| format!("d.set(\"kn\", d.z > 0.0047, {k:e});")).unwrap_or_default();
        let mut s = Session::new(
            "surgery_series_column",
            &format!(
                r#"let d = new_model("chain");
                let z = []; for k in 0..10 {{ z.push(0.0005 + 0.001 * k); }}
                d.add_elements(geometry(z.map(|v| 0.0), z.map(|v| 0.0), z, 0.0005), material_micro("soft", #{{ kn: 1e4, ks: 0.0, mu_p: 0.0, r: 0.0005 }}), "chain");
                d.connect("chain", 1e-9);
                {set}
                d.fix("chain", "xy"); d.fix([0], "xyz");
                d.gravity = [0.0, 0.0, -1000.0];
                d.damping = 0.3;
                d.set_standard_dt();
                d.run(40000);
                "#
            ),
        );
        let dz: f64 = s.eval("-d.dz[9]");
        let d = s.d();
        let data = d.data();
        let m = &data.sim.model;
        let w = m.particles.mass[1] * 1000.0;
        let k = |i: usize| m.element_values(matdem_engine::element_values::ElementValue::Kn)[i];
        let series = |a: f64, b: f64| (2.0 * a) * (2.0 * b) / (2.0 * a + 2.0 * b);
        let want: f64 = (1..10).map(|c| (10 - c) as f64 * w / series(k(c - 1), k(c))).sum();
        (dz, want)
    };
    let (soft, soft_want) = settle(None);
    let (mixed, mixed_want) = settle(Some(4e4));
    eprintln!("settlement: uniform {soft:e} (springs {soft_want:e}), upper half 4x stiffer {mixed:e} ({mixed_want:e})");
    assert!((soft / soft_want - 1.0).abs() < 1e-6, "uniform {soft} vs {soft_want}");
    assert!((mixed / mixed_want - 1.0).abs() < 1e-6, "two materials {mixed} vs {mixed_want}");
    // The stiffer half carries the lighter loads: 21 % less settlement, not 37.5 %.
    assert!(mixed < 0.8 * soft, "the stiffer upper half settles less: {mixed} vs {soft}");
}

/// The cutting test's pulled column (simple cubic, 4 × 4 × 16, bottom layer held, top layer
/// moved up slowly) with Xb and Fs0 set to 30 % on the elements of layer 8: the bonds that
/// touch the band are 30 % as strong (a bond takes the smaller Xb), so they break first —
/// every broken bond touches the band — and the peak pull is 30 % of the 16 vertical bonds'
/// 16·Kn·Xb within 10 % (the pull is dynamic).
#[test]
fn a_band_of_weaker_elements_breaks_first_under_tension() {
    let script = r#"
let D = 1e-3;
let d = new_model("column");
d.add_elements(make_lattice("sc", 4, 4, 16, D), material_micro("rock", #{ kn: 1e6, ks: 4e5, xb: 1e-5, fs0: 1e3, mu_p: 0.3, r: 0.5e-3 }), "column");
d.connect("column", 1e-9);
let band = (d.z > 7.5 * D) & (d.z < 8.5 * D);
d.set("xb", band, 3e-6);
d.set("fs0", band, 300.0);
d.group_where("bottom", d.z < 0.5 * D);
d.group_where("top", d.z > 14.5 * D);
d.fix("bottom", "z"); d.fix("top", "z");
d.damping = 0.1;
d.set_standard_dt();
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
let in_band = |z| z > 7.5 * D && z < 8.5 * D;
let touching = 0;
for k in 0..b.i.len() {
    if in_band.call(z0[b.i[k].to_int()]) || in_band.call(z0[b.j[k].to_int()]) { touching += 1; }
}
let first = if b.i.len() > 0 && (in_band.call(z0[b.i[0].to_int()]) || in_band.call(z0[b.j[0].to_int()])) { 1 } else { 0 };
print(`result ${b.i.len()} ${touching} ${first} ${peak} ${band.count()}`);
"#;
    let dir = temp_dir("surgery_weak_band");
    let o = run_script(&dir, "band.rhai", script, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let v: Vec<f64> = out
        .lines()
        .find(|l| l.starts_with("result "))
        .unwrap_or_else(|| panic!("{out}"))
        .split_whitespace()
        .skip(1)
        .map(|w| w.parse().unwrap())
        .collect();
    eprintln!("broken {}, touching the band {}, first in band {}, peak {} N, band {}", v[0], v[1], v[2], v[3], v[4]);
    assert_eq!(v[4], 16.0, "one layer of 16 elements");
    assert!(v[0] >= 16.0, "a whole section broke: {v:?}");
    assert_eq!(v[2], 1.0, "the first broken bond touches the band: {v:?}");
    assert_eq!(v[1], v[0], "every broken bond touches the band: {v:?}");
    let want = 16.0 * 1e6 * 3e-6;
    assert!((v[3] / want - 1.0).abs() < 0.1, "peak {} N vs 16·Kn·Xb_band = {want} N", v[3]);
}

/// Three elements stacked on a fixed one's top under gravity, no damping: the middle one is killed
/// while they rest, so the top one falls through where it is (overlapping it deeply on the
/// way, which any contact would have stopped) and lands on the bottom one. The killed one
/// never moves and is in no row; the kill books the energy it took (its contacts' springs)
/// as breakage heat, so the account is the same just after the kill as just before, and
/// stays so through the fall and the bounces (leapfrog, 1e-3 of the fall's energy).
#[test]
fn killed_elements_never_interact_again_and_the_energy_account_stays_continuous() {
    let mut s = Session::new(
        "surgery_kill_fall",
        r#"let d = new_model("stack");
        d.add_elements(geometry([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0005, 0.0015, 0.0025], 0.0005), material_micro("m", #{ kn: 1e4, ks: 4e3, mu_p: 0.3, r: 0.0005 }), "stack");
        d.connect("stack", 1e-9);
        d.fix("stack", "xy"); d.fix([0], "xyz");
        d.gravity = [0.0, 0.0, -9.81];
        d.set_standard_dt();
        d.damping = 0.5; d.run(20000); d.damping = 0.0;
        "#,
    );
    let before: f64 = s.eval("d.energies().total");
    let bonds_before: i64 = s.eval("d.bonds");
    let report: rhai::Map = s.eval("d.kill([1])");
    let after: f64 = s.eval("d.energies().total");
    let fall: f64 = s.eval("d.mass[2] * 9.81 * 0.001");
    eprintln!("kill: {report:?}; total {before:e} → {after:e}; fall energy {fall:e}");
    assert_eq!(report["killed"].as_int().unwrap(), 1);
    assert_eq!(report["bonds_broken"].as_int().unwrap(), 2, "the killed element's two bonds");
    assert_eq!(bonds_before, 2);
    assert!((after - before).abs() <= 1e-12 * fall, "a kill keeps the account: {before} → {after}");
    let heat: f64 = s.eval("d.energies().heat_breakage");
    assert!((heat - report["energy"].as_float().unwrap()).abs() <= 1e-15 + 1e-12 * heat.abs());
    assert_eq!(s.eval::<i64>("d.broken_bonds"), 0, "a kill is not a breakage");
    let z1: f64 = s.eval("d.z[1]");
    // The fall: about √(2·0.001/9.81) = 14 ms; run 40 ms, watching the gap as it passes.
    let (mut deepest, mut closest, mut in_flight, mut rebound) = (0.0f64, f64::INFINITY, None, 0.0f64);
    for _ in 0..400 {
        let gap: f64 = s.eval("d.run(100); (d.z[2] - d.z[1]).abs() - 0.001");
        deepest = deepest.min(gap);
        let sep: f64 = s.eval("d.z[2] - d.z[0]");
        if sep < closest {
            closest = sep;
            rebound = sep;
        }
        rebound = rebound.max(sep);
        // The account in free fall, overlapping the killed element, just before the impact.
        if in_flight.is_none() && sep < 1.1e-3 && sep > 1e-3 {
            in_flight = Some(s.eval::<f64>("d.energies().total"));
        }
        let d = s.d();
        let data = d.data();
        let c = &data.sim.model.contacts;
        if c.row_start.len() > 2 {
            assert!(c.row(1).is_empty(), "the killed element has a row");
            assert!(!c.other.contains(&1), "a row holds the killed element");
        }
    }
    let (z1_after, v1): (f64, f64) = (s.eval("d.z[1]"), s.eval("d.vz[1].abs() + d.vx[1].abs()"));
    // Read the account in flight, not in an impact: there the half-step velocities the
    // between-runs account uses are off by about F·v·dt/2.
    let total: f64 = s.eval("while d.z[2] - d.z[0] < 0.001 { d.run(10); } d.energies().total");
    eprintln!(
        "deepest overlap with the killed element {:e} m; closest approach to the bottom one {closest:e} m; total {total:e}",
        -deepest
    );
    assert!(deepest < -0.99e-3, "the top element passed through the killed one: {deepest}");
    assert_eq!((z1_after, v1), (z1, 0.0), "the killed element never moves");
    // It landed on the bottom one (sampled every 100 steps, 15 µm of the fall) and bounced
    // back up, elastic, most of the millimetre it fell.
    assert!(closest > 0.99e-3 && closest < 1.02e-3, "the top element came to the bottom one: {closest}");
    assert!(rebound > closest + 0.9e-3, "and bounced back: from {closest} to {rebound}");
    // In free fall the account's only error is the half-step kinetic energy, m·v·g·dt/2
    // (7e-5 of the fall); through the impacts leapfrog's (ω·dt)² (1e-2).
    let in_flight = in_flight.expect("a sample in the last 0.1 mm of the fall");
    eprintln!("total in flight {in_flight:e}, after the bounces {total:e}");
    assert!((in_flight - after).abs() < 2e-4 * fall, "the account in the fall: {after} → {in_flight}");
    assert!((total - after).abs() < 1e-2 * fall, "the account through the bounces: {after} → {total}");
    // Killed elements are out of the statistics and refuse velocities.
    let stats: rhai::Map = s.eval("d.mechanical_coordination()");
    assert_eq!(stats["counted"].as_int().unwrap() + stats["rattlers"].as_int().unwrap(), 2, "{stats:?}");
    let e = s.refusal("d.set(\"vz\", [1], 1.0)");
    assert!(e.contains("particle 1") && e.contains("killed"), "{e}");
    let e = s.refusal("d.set_velocity(\"stack\", [0.0, 0.0, 1.0])");
    assert!(e.contains("particle 1") && e.contains("killed"), "{e}");
    let _: Dynamic = s.eval("d.free([1], \"xyz\"); d.run(100); 0");
    assert_eq!(s.eval::<f64>("d.z[1]"), z1, "free() does not revive a killed element");
    assert_eq!(s.eval::<i64>("d.killed.count()"), 1);
    assert!(s.refusal("d.kill([7])").contains('7'));
}

/// A kill during a run on the GPU backend: the device's row builds leave the killed elements
/// out and its wall pass skips them, as the CPU does. A bonded box under raised gravity has a
/// ball of elements killed in its middle and runs on; the killed stay where they were, the rest
/// close in on them, and the CPU and GPU runs agree (positions within 2e-3, as the other GPU
/// surgery test).
#[test]
fn a_kill_during_a_run_agrees_on_the_gpu() {
    let dir = temp_dir("surgery_kill_gpu");
    let script = format!(
        r#"{SMALL_BOX}
        d.gravity = [0.0, 0.0, -200.0];
        d.run(300);
        let ball = d.in_sphere(0.002, 0.002, 0.001, 0.0009);
        let z0 = d.z.select(ball);
        let r = d.kill(ball);
        d.run(1500);
        let moved = (d.z.select(ball) - z0).abs().max() * 1e12;
        let alive = !d.killed;
        print(`killed=${{r.killed}} moved=${{moved}} zsum=${{fmt(d.z.select(alive).sum(), 9)}} coord=${{fmt(d.coordination_number(), 6)}}`);
        "#
    );
    let mut lines = Vec::new();
    for backend in ["cpu", "gpu"] {
        let o = run_script(&dir, "kill.rhai", &script, &["--backend", backend]);
        if backend == "gpu" && o.status.code() == Some(2) && !gpu_required() {
            eprintln!("skipped: no GPU adapter");
            return;
        }
        assert!(o.status.success(), "{backend}: {}", stderr(&o));
        lines.push(stdout(&o).lines().find(|l| l.starts_with("killed=")).unwrap().to_string());
    }
    eprintln!("cpu: {}\ngpu: {}", lines[0], lines[1]);
    let num = |l: &str, key: &str| -> f64 { l.split(key).nth(1).unwrap().split(' ').next().unwrap().parse().unwrap() };
    let (cpu, gpu) = (&lines[0], &lines[1]);
    assert!(num(cpu, "killed=") > 0.0 && num(cpu, "killed=") == num(gpu, "killed="), "{cpu} / {gpu}");
    // In pm: the GPU keeps positions as an f32 origin plus an f32 remainder, so a position
    // comes back within round-off of the f64 one even when it did not move.
    for l in [cpu, gpu] {
        assert!(num(l, "moved=") < 1.0, "a killed element moved: {l}");
    }
    let (a, b) = (num(cpu, "zsum="), num(gpu, "zsum="));
    assert!((a - b).abs() <= 2e-3 * a.abs(), "cpu {a} vs gpu {b}");
    let (a, b) = (num(cpu, "coord="), num(gpu, "coord="));
    assert!((a - b).abs() <= 0.1 * a, "coordination cpu {a} vs gpu {b}");
}

/// The GPU's own row builds leave a killed element out: the three-element stack of
/// `killed_elements_never_interact_again…` with its middle killed, run on both backends until
/// the top has fallen 0.78 mm through where the killed element sits (the device rebuilds the
/// rows as it drifts). Both match free fall, z = z0 − g·t²/2, within 2 µm (leapfrog's g·dt·t/2
/// and f32), and agree with each other within 1 µm; the killed element has not moved.
#[test]
fn a_killed_element_is_passed_through_on_the_gpu_as_on_the_cpu() {
    let dir = temp_dir("surgery_kill_fall_gpu");
    let script = r#"let d = new_model("stack");
        d.add_elements(geometry([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0005, 0.0015, 0.0025], 0.0005), material_micro("m", #{ kn: 1e4, ks: 4e3, mu_p: 0.3, r: 0.0005 }), "stack");
        d.connect("stack", 1e-9);
        d.fix("stack", "xy"); d.fix([0], "xyz");
        d.gravity = [0.0, 0.0, -9.81];
        d.set_standard_dt();
        d.damping = 0.5; d.run(20000); d.damping = 0.0;
        let z1 = d.z[1]; let z2 = d.z[2];
        d.kill([1]);
        let t0 = d.time;
        d.run(12000);
        let t = d.time - t0;
        print(`fall top=${fmt((z2 - d.z[2]) * 1e6, 4)} free=${fmt(4.905 * t * t * 1e6, 4)} killed=${fmt((d.z[1] - z1) * 1e6, 6)}`);
        "#;
    let mut lines = Vec::new();
    for backend in ["cpu", "gpu"] {
        let o = run_script(&dir, "fall.rhai", script, &["--backend", backend]);
        if backend == "gpu" && o.status.code() == Some(2) && !gpu_required() {
            eprintln!("skipped: no GPU adapter");
            return;
        }
        assert!(o.status.success(), "{backend}: {}", stderr(&o));
        lines.push(stdout(&o).lines().find(|l| l.starts_with("fall ")).unwrap().to_string());
    }
    eprintln!("cpu: {}\ngpu: {}", lines[0], lines[1]);
    let num = |l: &str, key: &str| -> f64 { l.split(key).nth(1).unwrap().split(' ').next().unwrap().parse().unwrap() };
    for l in &lines {
        let (top, free) = (num(l, "top="), num(l, "free="));
        assert!(free > 700.0 && (top - free).abs() < 2.0, "the top fell freely (µm): {l}");
        assert!(num(l, "killed=").abs() < 1e-3, "the killed element moved: {l}");
    }
    assert!((num(&lines[0], "top=") - num(&lines[1], "top=")).abs() < 1.0, "{lines:?}");
}
