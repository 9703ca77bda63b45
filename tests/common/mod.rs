//! Helpers for the host's end-to-end tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_matdem-rs"))
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
