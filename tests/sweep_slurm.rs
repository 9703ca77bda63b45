//! `matdem-rs sweep slurm --submit` against a real Slurm (`.ci/slurm-up start` brings up a
//! one-node cluster; `.ci/run` does it before the tests and sets MATDEM_REQUIRE_SLURM=1, so
//! there this test fails instead of skipping). A packaged simulator's 5-point sweep runs as a
//! job array; one point's value is out of the package's range, fails with that reason, and
//! the others complete; the merged table equals that of the same sweep run locally, byte
//! for byte (CPU backend, which is deterministic).

use crate::common::*;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const MANIFEST: &str = r#"(
    name: "settle",
    version: "0.1.0",
    description: "a few grains settling under gravity",
    entry: "settle.rhai",
    parameters: [
        (name: "seed", type: int, default: 1, range: (0, 100), help: "random packing"),
        (name: "g", type: float, default: 9.81, unit: "m/s²", range: (0.0, 100.0), help: "gravity"),
    ],
)"#;

const SCRIPT: &str = r#"
let b = new_box("settle");
b.sample_w = 0.003; b.sample_l = 0.003; b.sample_h = 0.004; b.ball_r = 0.4e-3; b.seed = params.seed;
let d = b.build_initial_model();
d.gravity = [0.0, 0.0, -params.g];
d.set_standard_dt();
d.balance("standard");
report("zmean", d.z.mean());
report("elements", d.z.len());
"#;

fn slurm_required() -> bool {
    std::env::var("MATDEM_REQUIRE_SLURM").is_ok_and(|v| v == "1")
}

fn ok(o: &Output) {
    assert!(o.status.success(), "exit {:?}\nstdout:\n{}\nstderr:\n{}", o.status.code(), stdout(o), stderr(o));
}

fn sweep(args: &[&str], dir: &Path) -> Output {
    bin().arg("sweep").args(args).arg(dir).output().unwrap()
}

#[test]
fn a_sweep_submitted_to_slurm_equals_the_same_sweep_run_locally() {
    let idle = Command::new("sinfo").args(["-h", "-o", "%t"]).output();
    let up = idle.as_ref().is_ok_and(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).contains("idle"));
    if !up {
        let why = match &idle {
            Err(e) => format!("no sinfo ({e})"),
            Ok(o) => format!("sinfo shows no idle node: {}{}", stdout(o), stderr(o)),
        };
        assert!(!slurm_required(), "MATDEM_REQUIRE_SLURM=1 but Slurm is not up: {why}");
        eprintln!("skipped: {why}; `.ci/slurm-up start` (as root) brings up a one-node Slurm");
        return;
    }
    let dir = temp_dir("sweep_slurm");
    let package = dir.join("settle");
    std::fs::create_dir_all(&package).unwrap();
    std::fs::write(package.join("simulator.ron"), MANIFEST).unwrap();
    std::fs::write(package.join("settle.rhai"), SCRIPT).unwrap();
    let (cluster, local) = (dir.join("cluster"), dir.join("local"));
    for sw in [&cluster, &local] {
        let o = bin()
            .args(["sweep", "plan"])
            .arg(&package)
            .arg("--out")
            .arg(sw)
            .args(["--vary", "seed=1,2,3,4,101", "--set", "g=9.81", "--backend", "cpu"])
            .output()
            .unwrap();
        ok(&o);
        assert!(
            stderr(&o).contains("warning: run05 will fail") && stderr(&o).contains("out of range"),
            "{}",
            stderr(&o)
        );
    }
    let submitted = bin().args(["sweep", "slurm"]).arg(&cluster).args(["--time", "5", "--submit"]).output().unwrap();
    ok(&submitted);
    let job = stdout(&submitted).trim().to_string();
    assert!(!job.is_empty() && job.chars().all(|c| c.is_ascii_digit()), "job id: {job:?}");
    // Meanwhile, the same sweep here.
    ok(&sweep(&["run", "--local", "-j", "2"], &local));
    let start = Instant::now();
    let status = loop {
        let s = sweep(&["status"], &cluster);
        ok(&s);
        let text = stdout(&s);
        if text.contains("0 running, 0 interrupted, 0 pending") {
            break text;
        }
        assert!(start.elapsed() < Duration::from_secs(180), "job {job} not done after 180 s:\n{text}");
        std::thread::sleep(Duration::from_millis(250));
    };
    assert!(status.contains("5 point(s): 4 ok, 1 failed"), "{status}");
    assert!(status.contains("run05 seed=101: failed:") && status.contains("out of range"), "{status}");
    // Each point ran as its own array task: Slurm's log of each task is there.
    for k in 0..5 {
        let log = cluster.join(format!("slurm/{job}_{k}.out"));
        assert!(log.is_file(), "{} missing: the array task did not run", log.display());
    }
    for sw in [&cluster, &local] {
        ok(&sweep(&["collect"], sw));
    }
    let a = std::fs::read_to_string(cluster.join("sweep.csv")).unwrap();
    let b = std::fs::read_to_string(local.join("sweep.csv")).unwrap();
    assert_eq!(a, b, "the cluster's table differs from the local one");
    assert_eq!(a.lines().filter(|l| l.contains(",ok,")).count(), 4, "{a}");
}
