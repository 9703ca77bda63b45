//! MatDEM's build → test workflow across scripts: `d.save` in one script, `load_model` in the
//! next, continuing exactly as one script would; damaged or missing files refused clearly.

use crate::common::{bin, stderr, temp_dir};
use std::path::Path;
use std::process::Output;

const BUILD: &str = r#"
let b = new_box("built");
b.sample_w = 4e-3; b.sample_l = 4e-3; b.sample_h = 5e-3;
b.ball_r = 0.5e-3; b.distri_rate = 0.2; b.seed = 3;
b.set_type("top_platen");
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, r: 0.5e-3, mu_p: 0.5, restitution: 0.5 }));
d.set_standard_dt();
d.gravity = [0.0, 0.0, -500.0];
d.run(1500);
d.connect("all", 2e-5);
d.record(#{ phase: 1 });
"#;

const TEST: &str = r#"
d.set_platen_stress("top_platen", 500.0);
d.run(1000);
d.record(#{ phase: 2 });
d.status.save("test.csv");
"#;

fn run(dir: &Path, name: &str, script: &str, out: &Path) -> Output {
    let path = dir.join(name);
    std::fs::write(&path, script).unwrap();
    bin().arg("run").arg(&path).arg("--out").arg(out).output().unwrap()
}

#[test]
fn a_model_saved_by_one_script_and_loaded_by_the_next_continues_like_one_script() {
    let dir = temp_dir("ck_workflow");
    let one = run(&dir, "one.rhai", &format!("{BUILD}{TEST}"), &dir.join("one"));
    assert!(one.status.success(), "{}", stderr(&one));

    let built = run(&dir, "build.rhai", &format!("{BUILD}d.save(\"built\");"), &dir.join("two"));
    assert!(built.status.success(), "{}", stderr(&built));
    assert!(dir.join("two/built.mdem").is_file());
    let test = run(&dir, "test.rhai", &format!("let d = load_model(\"built\");{TEST}"), &dir.join("two"));
    assert!(test.status.success(), "{}", stderr(&test));
    // The records travel with the model: both tables hold phase 1 and phase 2, bit for bit.
    let (a, b) = (std::fs::read(dir.join("one/test.csv")).unwrap(), std::fs::read(dir.join("two/test.csv")).unwrap());
    assert_eq!(String::from_utf8_lossy(&a).lines().count(), 3);
    assert!(a == b, "split run differs:\n{}\n{}", String::from_utf8_lossy(&a), String::from_utf8_lossy(&b));

    // A checkpoint beside the script is found too (another output folder, no copy there).
    std::fs::copy(dir.join("two/built.mdem"), dir.join("built.mdem")).unwrap();
    let beside = run(&dir, "test.rhai", &format!("let d = load_model(\"built\");{TEST}"), &dir.join("three"));
    assert!(beside.status.success(), "{}", stderr(&beside));
    assert!(std::fs::read(dir.join("three/test.csv")).unwrap() == b);
}

#[test]
fn a_corrupted_checkpoint_is_refused_naming_the_file_and_what_to_do() {
    let dir = temp_dir("ck_corrupt");
    let built = run(&dir, "build.rhai", &format!("{BUILD}d.save(\"built\");"), &dir.join("out"));
    assert!(built.status.success(), "{}", stderr(&built));
    let path = dir.join("out/built.mdem");
    let mut bytes = std::fs::read(&path).unwrap();
    let k = bytes.len() / 3;
    bytes[k] = !bytes[k];
    std::fs::write(&path, &bytes).unwrap();
    let o = run(&dir, "test.rhai", "let d = load_model(\"built\");", &dir.join("out"));
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("built.mdem") && e.contains("corrupt") && e.contains("save the model again"), "{e}");
    assert!(e.contains("test.rhai:1"), "the error points at the script line: {e}");

    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = stderr(&run(&dir, "test.rhai", "let d = load_model(\"built\");", &dir.join("out")));
    assert!(e.contains("truncated"), "{e}");
}

#[test]
fn loading_a_missing_checkpoint_says_where_it_looked() {
    let dir = temp_dir("ck_missing");
    let o = run(&dir, "test.rhai", "let d = load_model(\"nowhere\");", &dir.join("out"));
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("nowhere.mdem") && e.contains("looked for") && e.contains("d.save"), "{e}");
}

#[test]
fn saving_or_loading_outside_the_allowed_folders_is_refused() {
    let dir = temp_dir("ck_escape");
    let o = run(&dir, "esc.rhai", &format!("{BUILD}d.save(\"../escaped\");"), &dir.join("out"));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("outside the allowed folders"), "{}", stderr(&o));
    assert!(!dir.join("escaped.mdem").exists());
    let o = run(&dir, "esc.rhai", "load_model(\"/etc/passwd\");", &dir.join("out"));
    assert!(stderr(&o).contains("outside the allowed folders"), "{}", stderr(&o));
}
