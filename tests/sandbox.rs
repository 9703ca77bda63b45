//! The sandbox: a deliberately hostile package (tests/hostile/) tries each way out — `..`,
//! absolute paths, symbolic links, imports, an endless loop, deep recursion, huge data — and
//! each fails with a message that names the path or the limit and says what is allowed.

use crate::common::*;
use std::path::{Path, PathBuf};
use std::process::Output;

/// A copy of the hostile package in a fresh folder, with a symbolic link to /etc inside it.
fn hostile_copy(name: &str) -> PathBuf {
    let dir = temp_dir(name);
    let pkg = dir.join("hostile");
    std::fs::create_dir_all(&pkg).unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile");
    for f in ["simulator.ron", "hostile.rhai"] {
        std::fs::copy(src.join(f), pkg.join(f)).unwrap();
    }
    std::os::unix::fs::symlink("/etc", pkg.join("link_out")).unwrap();
    pkg
}

fn attack(pkg: &Path, name: &str, extra: &[&str]) -> (Output, String) {
    let out = pkg.parent().unwrap().join(format!("out_{name}"));
    let o = bin()
        .arg("run")
        .arg(pkg)
        .args(["--set", &format!("attack={name}"), "--out"])
        .arg(&out)
        .args(extra)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "attack {name} must fail as a script error:\n{err}");
    assert!(!stdout(&o).contains("root:"), "attack {name} leaked /etc/passwd");
    (o, err)
}

#[test]
fn reads_outside_the_package_folder_are_refused_with_the_path_named() {
    let pkg = hostile_copy("sandbox_reads");
    let (_, e) = attack(&pkg, "read_dotdot", &[]);
    assert!(e.contains("path `../../Cargo.toml` is outside the allowed folders (`..` climbs out)"), "{e}");
    let (_, e) = attack(&pkg, "read_absolute", &[]);
    assert!(e.contains("path `/etc/passwd` is outside the allowed folders (an absolute path)"), "{e}");
    let (_, e) = attack(&pkg, "read_symlink", &[]);
    assert!(e.contains("path `link_out/passwd` is outside the allowed folders (a symbolic link leads out"), "{e}");
    let (_, e) = attack(&pkg, "import_dotdot", &[]);
    assert!(e.contains("path `../../escape.rhai` is outside the allowed folders"), "{e}");
}

#[test]
fn writes_outside_the_output_folder_are_refused_with_the_path_named() {
    let pkg = hostile_copy("sandbox_writes");
    let (_, e) = attack(&pkg, "table_dotdot", &[]);
    assert!(e.contains("output path `../../x.csv` is outside the allowed folders (`..` climbs out)"), "{e}");
    assert!(!pkg.parent().unwrap().parent().unwrap().join("x.csv").exists());
    let (_, e) = attack(&pkg, "plot_absolute", &[]);
    assert!(e.contains("output path `/tmp/x.svg` is outside the allowed folders (an absolute path)"), "{e}");

    // A link planted in the output folder does not lead the script out either.
    let target = pkg.parent().unwrap().join("elsewhere");
    std::fs::create_dir_all(&target).unwrap();
    let out = pkg.parent().unwrap().join("out_write_symlink");
    std::fs::create_dir_all(&out).unwrap();
    std::os::unix::fs::symlink(&target, out.join("escape")).unwrap();
    let (_, e) = attack(&pkg, "write_symlink", &[]);
    assert!(e.contains("output path `escape/x.csv` is outside the allowed folders (a symbolic link leads out"), "{e}");
    assert!(!target.join("x.csv").exists());
    // Checkpoints go through the same gate (Host::out_path, Host::read_input).
    let (_, e) = attack(&pkg, "save_dotdot", &[]);
    assert!(e.contains("output path `../../x") && e.contains("is outside the allowed folders"), "{e}");
    assert!(!pkg.parent().unwrap().parent().unwrap().join("x.mdem").exists());
    let (_, e) = attack(&pkg, "load_absolute", &[]);
    assert!(e.contains("`/etc/passwd") && e.contains("is outside the allowed folders"), "{e}");
}

#[test]
fn endless_loops_deep_recursion_and_huge_data_stop_at_the_limits() {
    let pkg = hostile_copy("sandbox_limits");
    let (_, e) = attack(&pkg, "endless_loop", &["--max-operations", "200000"]);
    assert!(e.contains("too many operations") && e.contains("--max-operations"), "{e}");
    let (_, e) = attack(&pkg, "deep_recursion", &[]);
    assert!(e.contains("too many nested function calls") && e.contains("--max-call-depth"), "{e}");
    let (_, e) = attack(&pkg, "huge_array", &[]);
    assert!(e.contains("too large for the sandbox's limit") && e.contains("--max-array-size"), "{e}");
    let (_, e) = attack(&pkg, "huge_string", &[]);
    assert!(e.contains("too large for the sandbox's limit") && e.contains("--max-string-size"), "{e}");
}

#[test]
fn the_default_operation_limit_stops_an_endless_loop() {
    let pkg = hostile_copy("sandbox_default_limit");
    let t = std::time::Instant::now();
    let (_, e) = attack(&pkg, "endless_loop", &[]);
    assert!(e.contains("too many operations"), "{e}");
    eprintln!("the default limit stopped an endless loop after {:.1} s", t.elapsed().as_secs_f64());
}

#[test]
fn the_harmless_path_of_the_hostile_package_runs() {
    let pkg = hostile_copy("sandbox_harmless");
    let o = bin().arg("run").arg(&pkg).arg("--out").arg(pkg.parent().unwrap().join("out")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "harmless");
}

#[test]
fn scripts_see_no_file_process_network_or_environment_functions() {
    let host = std::rc::Rc::new(matdem_rs::api::Host::new(temp_dir("sandbox_fns")));
    let engine = matdem_rs::new_engine(host);
    let forbidden = [
        "exec",
        "system",
        "spawn",
        "command",
        "run_command",
        "shell",
        "env",
        "getenv",
        "set_env",
        "open",
        "open_file",
        "read_file",
        "write_file",
        "remove_file",
        "delete_file",
        "socket",
        "http",
        "fetch",
        "connect_tcp",
    ];
    let leaks: Vec<String> = engine
        .gen_fn_signatures(true)
        .into_iter()
        .filter(|sig| forbidden.contains(&sig.split('(').next().unwrap_or("").trim()))
        .collect();
    assert!(leaks.is_empty(), "functions a sandboxed script must not see: {leaks:?}");
    // Reads go through the sandbox; without a script folder there is nothing to read.
    let e = engine.eval::<String>(r#"read_text("x.csv")"#).unwrap_err().to_string();
    assert!(e.contains("no script folder"), "{e}");
}

#[test]
fn the_run_record_resume_point_and_lock_cannot_be_written_by_the_script() {
    let pkg = hostile_copy("sandbox_host_owned");
    for (name, file) in [("run_record", "run.ron"), ("resume_journal", "resume"), ("lock_file", ".matdem-rs.lock")] {
        let (_, e) = attack(&pkg, name, &[]);
        assert!(e.contains(&format!("`{file}` in the output folder belongs to matdem-rs")), "{name}: {e}");
    }
    let record = std::fs::read_to_string(pkg.parent().unwrap().join("out_run_record/run.ron")).unwrap();
    assert!(record.contains("script_sha256") && record.contains("status: \"failed\""), "{record}");
}

/// The hostile package with its manifest's name (or version) replaced, as an archive built
/// by hand (`pack` refuses such a manifest), in `dir`.
fn renamed_archive(dir: &Path, name: &str, version: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile");
    let manifest = std::fs::read_to_string(src.join("simulator.ron"))
        .unwrap()
        .replace("name: \"hostile\"", &format!("name: {name:?}"))
        .replace("version: \"0.0.1\"", &format!("version: {version:?}"))
        .replace("default: \"none\"", "default: \"bashrc\"");
    let mut b = tar::Builder::new(Vec::new());
    for (file, bytes) in
        [("simulator.ron", manifest.into_bytes()), ("hostile.rhai", std::fs::read(src.join("hostile.rhai")).unwrap())]
    {
        let mut h = tar::Header::new_ustar();
        h.set_size(bytes.len() as u64);
        h.set_mode(0o644);
        b.append_data(&mut h, file, bytes.as_slice()).unwrap();
    }
    let path = dir.join("renamed.tar");
    std::fs::write(&path, b.into_inner().unwrap()).unwrap();
    path
}

#[test]
fn a_manifest_name_or_version_that_is_a_path_is_refused_before_anything_runs_or_packs() {
    let victim = std::env::temp_dir().join(format!("matdem-victim-{}", std::process::id()));
    let names =
        [victim.display().to_string(), "../../x".into(), "..".into(), ".bashrc".into(), "a/b".into(), String::new()];
    for name in &names {
        let dir = temp_dir("sandbox_manifest_name");
        let archive = renamed_archive(&dir, name, "1.0");
        // No --out: the default output folder is where the name would lead.
        let o = bin().arg("run").arg(&archive).current_dir(&dir).output().unwrap();
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "name {name:?}: {e}");
        assert!(e.contains(&format!("name `{}` is refused", name.escape_debug())), "name {name:?}: {e}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "name {name:?} wrote beside the archive");

        // `pack` refuses the same manifest from a folder, before creating anything.
        let pkg = dir.join("pkg");
        std::fs::create_dir_all(&pkg).unwrap();
        let mut files = tar::Archive::new(std::fs::File::open(&archive).unwrap());
        files.unpack(&pkg).unwrap();
        let o = bin().arg("pack").arg(&pkg).current_dir(&dir).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "pack of name {name:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("is refused"), "{}", stderr(&o));
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2, "pack of name {name:?} created something");
    }
    assert!(!victim.exists(), "{} was created", victim.display());
    let dir = temp_dir("sandbox_manifest_version");
    let o = bin().arg("info").arg(renamed_archive(&dir, "ok", "../../1")).output().unwrap();
    assert!(stderr(&o).contains("version `../../1` is refused"), "{}", stderr(&o));

    // A well-named package writes its `.bashrc` (harmless) inside out/NAME, nowhere else.
    let dir = temp_dir("sandbox_manifest_ok");
    let o = bin().arg("run").arg(renamed_archive(&dir, "victim", "1.0")).current_dir(&dir).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("out/victim/.bashrc").is_file());
}
