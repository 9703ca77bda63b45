//! `d.rotate_group` (MatDEM's rotateGroup) and `d.export_elements` (the elements as a CSV table or a
//! ParaView file in the run's output folder) through the CLI: exact rigid rotations, files
//! whose rows round-trip bit for bit, and bad input refused by name with the model unchanged.

use crate::common::*;

/// A 3 × 2 × 1 simple-cubic block of 1 mm elements in group "block", the first at the origin.
const BLOCK: &str = r#"
let d = new_model("m");
d.add_elements(make_lattice("sc", 3, 2, 1, 2e-3), material_micro("m", #{ kn: 1e5, ks: 4e4, r: 1e-3 }), "block");
"#;

#[test]
fn rotate_group_turns_a_group_rigidly_about_a_point() {
    let dir = temp_dir("rotate_group");
    let script = format!(
        r#"{BLOCK}
        d.add_group("corner", [5]);
        let x0 = d.x; let y0 = d.y; let z0 = d.z;
        // A quarter turn about z through (2 mm, 0, 0): (x, y) → (2e-3 − y, x − 2e-3).
        let n = d.rotate_group("block", [0.0, 0.0, 1.0], 90.0, [2e-3, 0.0, 0.0]);
        let ex = 2e-3 - y0; let ey = x0 - 2e-3;
        print(`n ${{n}} err ${{max((d.x - ex).abs().max(), (d.y - ey).abs().max())}} z ${{(d.z - z0).abs().max()}}`);
        // A full turn in four quarter turns about a tilted axis comes back.
        let x1 = d.x; let y1 = d.y; let z1 = d.z;
        for k in 0..4 {{ d.rotate_group("all", [1.0, 1.0, 1.0], 90.0, [0.0, 1e-3, 0.0]); }}
        print(`back ${{max(max((d.x - x1).abs().max(), (d.y - y1).abs().max()), (d.z - z1).abs().max())}}`);
        // Only the group moves; distances inside it are kept.
        let before = d.x;
        d.rotate_group("corner", [0.0, 1.0, 0.0], 30.0, [0.0, 0.0, 0.0]);
        print(`others ${{((d.x - before).abs().select(!d.in_group("corner"))).max()}}`);
        d.set_standard_dt();
        d.run(10);
        "#
    );
    let o = run_script(&dir, "rot.rhai", &script, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let value = |key: &str| -> f64 {
        let line = out.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("no {key} in {out}"));
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    assert_eq!(value("n"), 6.0);
    let e = out.lines().find(|l| l.starts_with("n ")).unwrap();
    let nums: Vec<f64> = e.split_whitespace().filter_map(|w| w.parse().ok()).collect();
    assert!(nums[1] < 1e-18, "quarter turn off by {} m: {out}", nums[1]);
    assert!(nums[2] == 0.0, "a turn about z moved z: {out}");
    assert!(value("back") < 1e-16, "{out}");
    assert_eq!(value("others"), 0.0, "{out}");
}

#[test]
fn rotate_group_refuses_bad_input_and_changes_nothing() {
    let dir = temp_dir("rotate_group_bad");
    let cases = [
        (r#"d.rotate_group("block", [0.0, 0.0, 0.0], 10.0, [0.0, 0.0, 0.0])"#, "rotation axis is [0, 0, 0]"),
        (r#"d.rotate_group("block", [0.0, 0.0, 1.0], parse_float("inf"), [0.0, 0.0, 0.0])"#, "rotate_group: angle"),
        (r#"d.rotate_group("block", [0.0, 0.0], 10.0, [0.0, 0.0, 0.0])"#, "rotate_group: axis: expected [x, y, z]"),
        (r#"d.rotate_group("nope", [0.0, 0.0, 1.0], 10.0, [0.0, 0.0, 0.0])"#, "nope"),
    ];
    for (k, (call, expected)) in cases.iter().enumerate() {
        let script = format!(
            "{BLOCK}\nlet x0 = d.x;\ntry {{ {call}; }} catch (e) {{ print(`error: ${{e}}`); }}\nprint(`same ${{(d.x - x0).abs().max()}}`);"
        );
        let o = run_script(&dir, &format!("bad{k}.rhai"), &script, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = stdout(&o);
        assert!(out.contains("error:") && out.contains(expected), "{call}: expected `{expected}` in {out}");
        assert!(out.contains("same 0"), "{call} changed the model: {out}");
    }
}

#[test]
fn export_writes_every_element_to_the_output_folder_and_reads_back_bit_for_bit() {
    let dir = temp_dir("export");
    let script = format!(
        r#"{BLOCK}
        d.add_group("left", d.x < 1e-3);
        d.move_group("left", 0.0, 0.0, 1e-4);
        d.kill([5]);
        print(d.export_elements("block"));
        d.export_elements("block.vtp");
        "#
    );
    let o = run_script(&dir, "export.rhai", &script, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out_dir = dir.join("out");
    let csv = std::fs::read_to_string(out_dir.join("block.csv")).unwrap_or_else(|e| panic!("{e}: {}", stderr(&o)));
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), "id,x,y,z,r,vx,vy,vz,dx,dy,dz,material,groups,killed");
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(str::to_string).collect()).collect();
    assert_eq!(rows.len(), 6);
    // make_lattice("sc", 3, 2, 1, 2 mm): x = 2 mm·i, y = 2 mm·j; the left column raised 0.1 mm.
    for (k, row) in rows.iter().enumerate() {
        let f = |c: usize| row[c].parse::<f64>().unwrap();
        assert_eq!(row[0], k.to_string());
        assert_eq!(f(4), 1e-3, "{row:?}");
        assert_eq!(row[11], "m");
        let left = f(1) < 1e-3;
        assert_eq!(row[12], if left { "block;left" } else { "block" }, "{row:?}");
        assert_eq!(f(10), if left { 1e-4 } else { 0.0 }, "{row:?}");
        assert_eq!(f(3), if left { 1e-4 } else { 0.0 }, "{row:?}");
        assert_eq!(row[13], if k == 5 { "1" } else { "0" }, "{row:?}");
    }
    let vtp = std::fs::read_to_string(out_dir.join("block.vtp")).unwrap();
    assert!(vtp.contains("NumberOfPoints=\"6\""), "{vtp}");
    assert!(vtp.contains("Name=\"killed\" NumberOfComponents=\"1\" format=\"ascii\">0 0 0 0 0 1<"), "{vtp}");
    assert!(stdout(&o).contains("block.csv"), "{}", stdout(&o));
}

#[test]
fn export_stays_in_the_output_folder_and_refuses_other_formats() {
    let dir = temp_dir("export_bad");
    let cases = [
        (r#"d.export_elements("../escape.csv")"#, "escape.csv"),
        (r#"d.export_elements("/tmp/abs.csv")"#, "/tmp/abs.csv"),
        (r#"d.export_elements("block.txt")"#, "not .txt"),
    ];
    for (k, (call, expected)) in cases.iter().enumerate() {
        let script = format!("{BLOCK}\ntry {{ {call}; }} catch (e) {{ print(`error: ${{e}}`); }}");
        let o = run_script(&dir, &format!("bad{k}.rhai"), &script, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = stdout(&o);
        assert!(out.contains("error:") && out.contains(expected), "{call}: expected `{expected}` in {out}");
    }
    assert!(!dir.join("escape.csv").exists());
}
