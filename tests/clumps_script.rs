//! Clumps through the script API (issue 34 item 3): balls deposited in a box become clumps of a
//! template (`d.replace_with_clumps`), which settle under gravity as rigid bodies and come to
//! rest on the floor; the plan names the stage; a clump of a group (`d.clump`) and its body
//! (`d.clump_info`) read back; a bad template is refused with what to give.

use crate::common::{run_script, stderr, stdout, temp_dir};

#[test]
fn balls_replaced_by_clumps_settle_as_rigid_bodies() {
    let dir = temp_dir("clumps_script");
    let script = r#"
        let b = new_box("pile");
        b.sample_w = 0.006; b.sample_l = 0.006; b.sample_h = 0.006;
        b.ball_r = 0.5e-3; b.distri_rate = 0.1; b.seed = 2;
        let d = b.build_initial_model();
        d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, r: 0.5e-3, mu_p: 0.5, restitution: 0.5 }));
        let n_balls = d.group("sample").len();
        let z0 = d.z.mean();
        // A dumbbell of two touching spheres, and a three-sphere bent rod.
        let made = d.replace_with_clumps("sample", [[-0.5, 0.0, 0.0, 0.5], [0.5, 0.0, 0.0, 0.5]], 7);
        print(`clumps ${made.len() == n_balls} ${d.clump_count() == n_balls} ${d.n == 2 * n_balls}`);
        print(`grouped ${d.group("sample").len() == d.n}`);
        let c0 = d.clump_info(0);
        print(`info ${c0.members.len()} ${c0.mass > 0.0} ${c0.inertia[0] < c0.inertia[2]}`);
        d.set_standard_dt();
        d.gravity = [0.0, 0.0, -9.81 * 500.0];
        d.local_damping = 0.5;
        print(d.plan());
        let peak = 0.0;
        for k in 0..8 { d.run(4000); peak = max(peak, d.energies().kinetic); }
        print(`settled ${d.z.mean() < 0.5 * z0} ke ${d.energies().kinetic / peak}`);
        let c = d.clump_info(0);
        let gap = ((d.x[c.members[0]] - d.x[c.members[1]]) ** 2 + (d.y[c.members[0]] - d.y[c.members[1]]) ** 2
            + (d.z[c.members[0]] - d.z[c.members[1]]) ** 2) ** 0.5;
        print(`rigid ${(gap / (2.0 * d.r[c.members[0]]) - 1.0).abs() < 1e-9}`);
        // On the floor (z = 0) to within the overlap its contacts allow.
        print(`above ${(d.z - d.r).min() > -1e-5}`);
    "#;
    let out = run_script(&dir, "pile.rhai", script, &[]);
    let (so, se) = (stdout(&out), stderr(&out));
    assert!(out.status.success(), "{so}\n{se}");
    let line = |key: &str| so.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("no `{key}` in\n{so}"));
    assert_eq!(line("clumps"), "clumps true true true");
    assert_eq!(line("grouped"), "grouped true");
    assert_eq!(line("info"), "info 2 true true");
    assert!(so.contains("clumps(") && so.contains("rigid bodies of"), "{so}");
    assert!(line("settled").starts_with("settled true"), "{so}");
    let ke: f64 = line("settled").rsplit(' ').next().unwrap().parse().unwrap();
    assert!(ke < 1e-3, "the pile comes to rest: the kinetic energy {ke} of its peak");
    assert_eq!(line("rigid"), "rigid true");
    assert_eq!(line("above"), "above true");
}

#[test]
fn a_bad_template_is_refused_with_what_to_give() {
    let dir = temp_dir("clumps_bad");
    let script = r#"
        let b = new_box("few");
        b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
        let d = b.build_initial_model();
        d.replace_with_clumps("sample", [[0.0, 0.0, 0.0]]);
    "#;
    let out = run_script(&dir, "bad.rhai", script, &[]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("each sphere of the template is [x, y, z, r]"), "{}", stderr(&out));
}
