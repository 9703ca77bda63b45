//! Helpers for the host's end-to-end tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_matdem-rs"))
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
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
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
