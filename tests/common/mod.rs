//! Helpers for the host's end-to-end tests.
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_matdem-rs"))
}

/// `matdem-rs run <dir>/s.rhai --out <dir>/out --backend cpu`, to be given its streams and
/// started.
pub fn run_in(dir: &Path) -> Command {
    let mut c = bin();
    c.arg("run").arg(dir.join("s.rhai")).arg("--out").arg(dir.join("out")).args(["--backend", "cpu"]);
    c
}

/// The binary on a machine with no GPU driver at all: the Vulkan loader and EGL are pointed at
/// files that do not exist, so wgpu finds no adapter (not even Mesa's software one).
pub fn bin_without_gpu() -> Command {
    let mut c = bin();
    c.env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("__EGL_VENDOR_LIBRARY_DIRS", "/nonexistent")
        .env("__EGL_VENDOR_LIBRARY_FILENAMES", "/nonexistent/egl.json");
    c
}

/// Whether GPU tests must run (CI sets MATDEM_REQUIRE_GPU=1 after installing lavapipe).
pub fn gpu_required() -> bool {
    std::env::var("MATDEM_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// A fresh folder under the target directory (kept for inspection after a failure).
pub fn temp_dir(name: &str) -> PathBuf {
    // Every test file shares one binary and its tests run in parallel: libtest names each
    // test's thread after the test, so two files asking for the same name stay apart.
    let test = std::thread::current().name().unwrap_or("main").replace("::", "-");
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(test).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `script` to `dir/name` and runs it with `matdem-rs run`.
pub fn run_script(dir: &Path, name: &str, script: &str, extra: &[&str]) -> Output {
    let path = dir.join(name);
    std::fs::write(&path, script).unwrap();
    bin().arg("run").arg(&path).arg("--out").arg(dir.join("out")).args(extra).output().unwrap()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A small box of grains with a top platen, a material and the standard step: the scene of
/// the in-process script tests (`d` and `b`).
pub const SMALL_BOX: &str = r#"
let b = new_box("t");
b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.003;
b.ball_r = 0.4e-3; b.distri_rate = 0.2; b.seed = 7;
b.set_type("top_platen");
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("m", #{ kn: 2e5, ks: 8e4, mu_p: 0.3, r: 0.4e-3, restitution: 0.3 }));
d.set_standard_dt();
"#;

/// Runs the packaged example `examples/NAME` in quick mode with its outputs in `out`; panics
/// with its output if it fails, and returns its stdout and wall time (s).
pub fn run_example_quick(name: &str, out: &Path) -> (String, f64) {
    run_example_quick_with(name, out, &[])
}

/// [`run_example_quick`] with more parameters, each `"name=value"` (`--set`).
pub fn run_example_quick_with(name: &str, out: &Path, sets: &[&str]) -> (String, f64) {
    let start = std::time::Instant::now();
    let pkg = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name);
    let mut cmd = bin();
    cmd.arg("run").arg(&pkg).args(["--set", "quick=true"]);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let o = cmd.arg("--out").arg(out).output().unwrap();
    let wall = start.elapsed().as_secs_f64();
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    (stdout(&o), wall)
}

/// The `name,value` rows of a run's `metrics.csv`.
pub fn metrics(dir: &Path) -> HashMap<String, f64> {
    let text = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let (name, value) = l.split_once(',').unwrap();
            (name.to_string(), value.parse().unwrap())
        })
        .collect()
}

/// One numeric column of a CSV table with a header (a run's history), in row order.
pub fn csv_column(path: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let k = header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    lines.map(|l| l.split(',').nth(k).unwrap().parse().unwrap()).collect()
}

/// Starts `script` with `matdem-rs run` in a fresh folder `name`, waits for its first line on
/// stdout, sends SIGTERM and returns (exit code, seconds from the signal to the exit, the
/// run record).
pub fn terminate_after_first_line(name: &str, script: &str, extra: &[&str]) -> (Option<i32>, f64, String) {
    terminate_after_first_line_in(&temp_dir(name), script, extra)
}

/// [`terminate_after_first_line`] in `dir`, which may hold the files the script reads.
pub fn terminate_after_first_line_in(dir: &Path, script: &str, extra: &[&str]) -> (Option<i32>, f64, String) {
    use std::io::BufRead;
    std::fs::write(dir.join("s.rhai"), script).unwrap();
    let mut child = run_in(dir)
        .args(extra)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut first).unwrap();
    assert!(!first.is_empty(), "the script printed nothing");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let sent = std::time::Instant::now();
    assert!(std::process::Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap().success());
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if sent.elapsed().as_secs() > 20 {
            let _ = child.kill();
            panic!("{}: still running 20 s after SIGTERM", dir.display());
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let record = std::fs::read_to_string(dir.join("out/run.ron")).unwrap_or_default();
    (code, sent.elapsed().as_secs_f64(), record)
}
