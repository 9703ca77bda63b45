//! Periodic boundaries through the script API (issue 34 item 2): a settled box loses its side
//! walls and repeats along x and y instead (`d.periodic`); its elements settle on the floor under
//! gravity, every one inside the cell, the plan names the stage, `d.periodic_cell()` reads the
//! cell back; a cell too narrow for the elements is refused with what to do.

use crate::common::{run_script, stderr, stdout, temp_dir};

#[test]
fn a_box_without_side_walls_repeats_along_x_and_y() {
    let dir = temp_dir("periodic_script");
    let script = r#"
        let b = new_box("slab");
        b.sample_w = 0.006; b.sample_l = 0.006; b.sample_h = 0.004;
        b.ball_r = 0.4e-3; b.distri_rate = 0.2; b.seed = 5;
        let d = b.build_initial_model();
        d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, r: 0.4e-3, mu_p: 0.5, restitution: 0.5 }));
        d.set_standard_dt();
        for w in ["left", "right", "front", "back"] { d.remove_boundary(w); }
        d.periodic(#{ x: [0.0, 0.006], y: [0.0, 0.006] });
        d.gravity = [0.0, 0.0, -9.81 * 100.0];
        d.local_damping = 0.4;
        d.vx = d.vx + 0.05;
        print(d.plan());
        d.run(6000);
        let c = d.periodic_cell();
        print(`cell ${c.x[1]} ${c.y[1]} ${c.keys().len()}`);
        print(`inside ${d.x.min() >= 0.0 && d.x.max() < 0.006 && d.y.min() >= 0.0 && d.y.max() < 0.006}`);
        print(`floor ${(d.z - d.r).min() > -1e-5}`);
        print(`moved ${d.dx.abs().max()}`);
    "#;
    let out = run_script(&dir, "slab.rhai", script, &[]);
    let (so, se) = (stdout(&out), stderr(&out));
    assert!(out.status.success(), "{so}\n{se}");
    let line = |key: &str| so.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("no `{key}` in\n{so}"));
    assert!(so.contains("periodic(x ∈ [0.0000e0, 6.0000e-3), y ∈ [0.0000e0, 6.0000e-3))"), "{so}");
    assert_eq!(line("cell"), "cell 0.006 0.006 2");
    assert_eq!(line("inside"), "inside true");
    assert_eq!(line("floor"), "floor true");
}

#[test]
fn a_cell_too_narrow_for_its_elements_is_refused_with_what_to_do() {
    let dir = temp_dir("periodic_narrow");
    let script = r#"
        let b = new_box("few");
        b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
        let d = b.build_initial_model();
        d.periodic(#{ x: [0.0, 0.002] });
    "#;
    let out = run_script(&dir, "narrow.rhai", script, &[]);
    assert!(!out.status.success());
    let e = stderr(&out);
    assert!(e.contains("at least 3·(2·r_max + skin)") && e.contains("widen the cell"), "{e}");
}
