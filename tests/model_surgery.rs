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
        .eval::<matdem_rs::api::field::Mask>("let doomed = d.in_sphere(0.002, 0.002, 0.001, 0.0012); doomed")
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
