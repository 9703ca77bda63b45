//! Applied loads from a script (issue 31): `d.apply_force` / `d.apply_torque` take a group name,
//! an id array or a mask, as every model method does; three free elements (no gravity, no
//! contacts) accelerate at F/m and spin at T/I, their angles read back as `d.ax`/`d.ay`/`d.az`,
//! the work is in `d.energies()` and `d.record()`, the plan lists the stage only while a load is
//! on, and bad input is refused with a message that says what to do, changing nothing.

use matdem_rs::api::model::ModelHandle;
use matdem_rs::api::Host;
use rhai::{Array, Dynamic, Engine, Scope};
use std::rc::Rc;

struct Session {
    engine: Engine,
    scope: Scope<'static>,
}

impl Session {
    fn new(name: &str) -> Self {
        let host = Rc::new(Host::new(crate::common::temp_dir(name)));
        let mut s = Session { engine: matdem_rs::new_engine(host), scope: Scope::new() };
        // Three elements 1 cm apart (no contact), soft (kn 1 N/m: the guard's critical step stays
        // above dt), no gravity.
        let _: Dynamic = s.eval(
            r#"let d = new_model("free");
            let t = new_table();
            for x in [0.0, 0.01, 0.02] { t.add_row(#{ x: x, y: 0.0, z: 0.0, r: 1e-3 }); }
            d.add_elements(t, material_micro("m", #{ kn: 1.0, r: 1e-3 }), "balls");
            d.dt = 1e-5;"#,
        );
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

    fn loads(&self) -> String {
        let d = self.scope.get_value::<ModelHandle>("d").unwrap();
        let data = d.data();
        format!("{:?}", data.sim.model.particles.applied)
    }
}

// Ids, a mask and a group: element 0 pushed along x, element 2 (the mask x > 15 mm) along −z,
// every element twisted about z. After 1000 steps of 10 µs: v = F·t/m, ω = T·t/I and the angle
// the leapfrog's α·dt²·n(n+1)/2, each to 1e-12; the work is F·Δx + T·Δθ (in `d.energies()` and
// `d.record()`), and the account's total is what the leapfrog's half-step velocities give.
#[test]
fn a_script_applies_forces_and_torques_by_ids_mask_and_group_and_reads_the_angles() {
    let mut s = Session::new("applied_loads_script");
    let r: Array = s.eval(
        r#"let plan0 = d.plan();
        d.apply_force([0], [2e-4, 0.0, 0.0]);
        d.apply_force(d.x > 0.015, [0.0, 0.0, -1e-4]);
        d.apply_torque("balls", [0.0, 0.0, 1e-8]);
        let plan1 = d.plan();
        d.run(1000);
        d.record();
        let e = d.energies();
        let row = d.status.last("applied_work");
        [d.vx[0], d.vz[2], d.wz[1], d.az[1], d.x[0], d.z[2], d.mass[0], e.applied_work, e.total, row,
         plan0.contains("applied loads("), plan1.contains("applied loads(forces and torques on 3 element(s)"),
         d.applied_fx[0], d.applied_fz[2], d.applied_tz[1], d.applied_fx[1], d.ax[0]]"#,
    );
    let f = |k: usize| r[k].as_float().unwrap();
    let (t, n, dt, r0) = (1e-2, 1000.0, 1e-5, 1e-3);
    let mass = f(6);
    let inertia = 0.4 * mass * r0 * r0;
    let close = |got: f64, want: f64| ((got - want) / want).abs() < 1e-12;
    assert!(close(f(0), 2e-4 / mass * t), "vx {} against F·t/m {}", f(0), 2e-4 / mass * t);
    assert!(close(f(1), -1e-4 / mass * t), "vz {}", f(1));
    assert!(close(f(2), 1e-8 / inertia * t), "wz {} against T·t/I {}", f(2), 1e-8 / inertia * t);
    let steps = dt * dt * n * (n + 1.0) / 2.0;
    assert!(close(f(3), 1e-8 / inertia * steps), "az {}", f(3));
    assert!(close(f(4), 2e-4 / mass * steps), "x {}", f(4));
    // F·Δx + T·Δθ over the three elements.
    let work = 2e-4 * f(4) + 1e-4 * -f(5) + 3.0 * 1e-8 * f(3);
    assert!(close(f(7), work), "applied work {} against {work}", f(7));
    assert!(close(f(9), work), "d.record()'s applied_work {}", f(9));
    // `d.energies()` reads the stored (half-step) velocities, n·a·dt: their kinetic energy is
    // W·n/(n + 1) of each element's work W, so the total is −W/(n + 1) exactly (to 1e-9: the
    // difference of two numbers 1e3 times larger).
    assert!(((f(8) + work / (n + 1.0)) / (work / (n + 1.0))).abs() < 1e-9, "total {} against −W/(n+1)", f(8));
    assert!(!r[10].as_bool().unwrap() && r[11].as_bool().unwrap(), "the plan lists the stage only with loads");
    assert_eq!([f(12), f(13), f(14), f(15), f(16)], [2e-4, -1e-4, 1e-8, 0.0, 0.0]);

    // Zero and clear: the stage leaves the plan, the work stays.
    let r: Array = s.eval(
        r#"let w = d.energies().applied_work;
        d.apply_force("all", [0.0, 0.0, 0.0]);
        let still = d.plan().contains("applied loads(");
        d.clear_applied_loads();
        [still, d.plan().contains("applied loads("), d.energies().applied_work == w, d.applied_tz[0]]"#,
    );
    assert!(r[0].as_bool().unwrap(), "the torques are still on");
    assert!(!r[1].as_bool().unwrap() && r[2].as_bool().unwrap() && r[3].as_float().unwrap() == 0.0);
}

// Bad input: a NaN, an infinite value, a vector that is not three numbers, an unknown group (with
// a suggestion), a mask of the wrong length, an id beyond the model; each refused naming what is
// wrong, and the loads stay as they were. The angles without rotation are refused with the fix.
#[test]
fn bad_applied_loads_are_refused_and_change_nothing() {
    let mut s = Session::new("applied_loads_refusals");
    let e = s.refusal("d.ax");
    assert!(e.contains("rotation is off") && e.contains("d.enable(\"rotation\")"), "{e}");
    let _: Dynamic = s.eval(r#"d.apply_force([1], [1e-4, 0.0, 0.0]);"#);
    let before = s.loads();
    let cases: &[(&str, &[&str])] = &[
        (r#"d.apply_force("balls", [0.0, 0.0 / 0.0, 0.0])"#, &["apply_force", "3 finite numbers"]),
        (r#"d.apply_torque("balls", [1.0 / 0.0, 0.0, 0.0])"#, &["apply_torque", "3 finite numbers"]),
        (r#"d.apply_force("balls", [1.0, 2.0])"#, &["apply_force", "[x, y, z]"]),
        (r#"d.apply_force("bals", [1.0, 0.0, 0.0])"#, &["unknown group", "balls"]),
        (r#"d.apply_torque(field([1.0, 2.0]) > 0.0, [1.0, 0.0, 0.0])"#, &["mask has 2 entries", "3 particles"]),
        (r#"d.apply_force([7], [1.0, 0.0, 0.0])"#, &["7"]),
    ];
    for (script, words) in cases {
        let e = s.refusal(script);
        for w in *words {
            assert!(e.contains(w), "`{script}`: `{w}` not in: {e}");
        }
        assert_eq!(s.loads(), before, "`{script}` changed the loads");
    }
}
