//! Interrupt and resume: SIGTERM in the middle of `matdem-rs run` keeps the finished outputs,
//! saves a resume point and exits 130; `--resume` then ends with outputs equal bit for bit to
//! those of a run that was never interrupted (CPU backend). Also the run record.

use crate::common::{bin, stderr, temp_dir};
use std::io::Read;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Settles a ~300-grain box in stages (a few seconds in release): runs, lane reads,
/// energies, records and tables between the stages, then a tolerance balance and a save.
const SCRIPT: &str = r#"
let b = new_box("tiny");
b.ball_r = 0.5e-3; b.distri_rate = 0.2;
b.sample_w = 6e-3; b.sample_l = 6e-3; b.sample_h = 8e-3;
b.set_type("top_platen");
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, r: 0.5e-3, mu_p: 0.5, restitution: 0.5 }));
d.set_standard_dt();
d.gravity = [0.0, 0.0, -9.81 * 50.0];
d.local_damping = 0.3;
for k in 0..8 {
    d.run(2500);
    d.record(#{ stage: k, mean_z: d.z.mean(), ke: d.energies().kinetic });
    d.status.save("progress.csv");
    if k == 1 { d.connect("all", 1e-5); }
}
let r = d.balance_until(0.05, 4000);
d.record(#{ stage: 99, steps: r.steps });
d.status.save("final.csv");
d.save("settled");
print("done");
"#;

/// Kills the child on every path, so a failing test leaves no process behind.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn run(script: &Path, out: &Path) -> std::process::Output {
    bin().arg("run").arg(script).arg("--out").arg(out).output().unwrap()
}

/// `matdem-rs run SCRIPT --out OUT` in the background, its stderr piped.
fn spawn_run(script: &Path, out: &Path, stdout: Stdio) -> Running {
    Running(bin().arg("run").arg(script).arg("--out").arg(out).stdout(stdout).stderr(Stdio::piped()).spawn().unwrap())
}

/// Sends SIGTERM and waits: the exit status and what the run said on stderr.
fn interrupt(child: &mut Running) -> (std::process::ExitStatus, String) {
    assert!(Command::new("kill").arg("-TERM").arg(child.0.id().to_string()).status().unwrap().success());
    let status = child.0.wait().unwrap();
    let mut err = String::new();
    child.0.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (status, err)
}

/// Resumes the run in `out` to its end; each of `files` must then equal the uninterrupted run's
/// in `straight`, byte for byte.
fn resume_matches(script: &Path, out: &Path, straight: &Path, files: &[&str]) {
    let resumed = bin().arg("run").arg(script).arg("--resume").arg(out).output().unwrap();
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    for file in files {
        let (a, b) = (std::fs::read(straight.join(file)).unwrap(), std::fs::read(out.join(file)).unwrap());
        assert!(a == b, "{file} of the resumed run differs from the uninterrupted run's");
    }
}

#[test]
fn sigterm_mid_run_then_resume_ends_with_the_uninterrupted_outputs_bitwise() {
    let dir = temp_dir("resume_sigterm");
    let script = dir.join("tiny.rhai");
    std::fs::write(&script, SCRIPT).unwrap();

    let straight = run(&script, &dir.join("straight"));
    assert!(straight.status.success(), "{}", stderr(&straight));

    let out = dir.join("cut");
    let mut child = spawn_run(&script, &out, Stdio::null());
    // Interrupt once the first stage's table is written: well inside the run.
    let start = Instant::now();
    while !out.join("progress.csv").exists() {
        assert!(start.elapsed() < Duration::from_secs(60), "the run never wrote its first table");
        std::thread::sleep(Duration::from_millis(5));
    }
    let (status, err) = interrupt(&mut child);
    assert_eq!(status.code(), Some(130), "an interrupted run exits with 130: {err}");
    assert!(err.contains("--resume") && err.contains("stopped after"), "says how to continue: {err}");
    assert!(out.join("resume/journal.ron").is_file() && out.join("resume/model_0.mdem").is_file());
    assert!(!out.join("final.csv").exists(), "the interruption must land before the end of the run");
    assert!(out.join("progress.csv").is_file(), "finished outputs are kept");
    let record = std::fs::read_to_string(out.join("run.ron")).unwrap();
    assert!(record.contains("status: \"interrupted\"") && record.contains("exit_code: Some(130)"), "{record}");

    // A changed script is refused before anything runs.
    let changed = dir.join("changed.rhai");
    std::fs::write(&changed, SCRIPT.replace("0..8", "0..9")).unwrap();
    let o = bin().arg("run").arg(&changed).arg("--resume").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("has changed since the run was interrupted"), "{}", stderr(&o));

    resume_matches(&script, &out, &dir.join("straight"), &["final.csv", "progress.csv", "settled.mdem"]);
    assert!(!out.join("resume").exists(), "a finished run leaves nothing to resume");
    let record = std::fs::read_to_string(out.join("run.ron")).unwrap();
    assert!(record.contains("status: \"ok\"") && record.contains("resumed_from: Some("), "{record}");
}

#[test]
fn resume_without_a_resume_point_says_what_to_give() {
    let dir = temp_dir("resume_missing");
    let script = dir.join("tiny.rhai");
    std::fs::write(&script, "print(1);").unwrap();
    let o = bin().arg("run").arg(&script).arg("--resume").arg(dir.join("nothing")).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("give the output folder of an interrupted run"), "{}", stderr(&o));
}

#[test]
fn every_run_folder_records_the_script_hash_parameters_backend_and_exit() {
    let dir = temp_dir("run_record");
    let script = dir.join("fails.rhai");
    let text = "let x = params.a * 2;\nthrow \"stop\";\n";
    std::fs::write(&script, text).unwrap();
    let o = bin()
        .arg("run")
        .arg(&script)
        .arg("--out")
        .arg(dir.join("out"))
        .args(["--set", "a=1.5", "--backend", "cpu"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let record = std::fs::read_to_string(dir.join("out/run.ron")).unwrap();
    let sha = matdem_rs::run_record::sha256_hex(text.as_bytes());
    for want in [
        format!("script_sha256: \"{sha}\""),
        "(\"a\", \"1.5\")".to_string(),
        "backend: \"cpu (f64)\"".to_string(),
        format!("matdem_rs_version: \"{}\"", env!("CARGO_PKG_VERSION")),
        "status: \"failed\"".to_string(),
        "exit_code: Some(1)".to_string(),
        "finished: Some(\"20".to_string(),
    ] {
        assert!(record.contains(&want), "run.ron lacks {want}:\n{record}");
    }
}

/// A signal that lands in the script's own code between two balances (here a loop of
/// arithmetic) still leaves a resume point: the script goes on to its next run, which saves
/// one after its first chunk, and the resumed run ends as the uninterrupted one.
#[test]
fn sigterm_between_two_balances_still_leaves_a_resume_point() {
    let dir = temp_dir("resume_between");
    let script = dir.join("between.rhai");
    let text = r#"
let b = new_box("tiny");
b.ball_r = 0.5e-3; b.distri_rate = 0.2;
b.sample_w = 6e-3; b.sample_l = 6e-3; b.sample_h = 8e-3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, r: 0.5e-3, mu_p: 0.5, restitution: 0.5 }));
d.set_standard_dt();
d.gravity = [0.0, 0.0, -9.81 * 50.0];
d.run(500);
print("between");
let s = 0;
for i in 0..300000 { s += i % 7; }
d.record(#{ s: s, mean_z: d.z.mean() });
d.run(3000);
d.status.save("final.csv");
d.save("settled");
"#;
    std::fs::write(&script, text).unwrap();
    let straight = run(&script, &dir.join("straight"));
    assert!(straight.status.success(), "{}", stderr(&straight));

    let out = dir.join("cut");
    let mut child = spawn_run(&script, &out, Stdio::piped());
    // The loop after "between" takes tens of milliseconds: the signal lands in it (or, on a
    // slow day, in the run after it, which saves a resume point as before).
    let mut line = [0u8; 8];
    child.0.stdout.take().unwrap().read_exact(&mut line).unwrap();
    assert_eq!(&line, b"between\n");
    let (status, err) = interrupt(&mut child);
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(out.join("resume/journal.ron").is_file(), "a resume point is saved: {err}");
    assert!(!out.join("final.csv").exists(), "the interruption must land before the end of the run");

    resume_matches(&script, &out, &dir.join("straight"), &["final.csv", "settled.mdem"]);
}
