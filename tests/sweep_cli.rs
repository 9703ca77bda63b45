//! `matdem-rs sweep` on this machine: a sweep is a folder; its points run in parallel
//! processes, a failed point is recorded and the rest go on, finished points are never run
//! again, an interrupted sweep resumes and ends bit for bit as an uninterrupted one, a changed
//! source is refused, and the Slurm job array lists exactly the pending points.

use crate::common::*;
use std::path::Path;
use std::process::Output;

/// Reports 1/x, and refuses x = 0 the way an unstable setting would stop.
const INVERSE: &str = r#"
if params.x == 0 { throw "x must not be 0"; }
report("inverse", 1.0 / params.x + params.offset);
"#;

pub(crate) fn sweep(args: &[&str], dir: &Path) -> Output {
    bin().arg("sweep").args(args).arg(dir).output().unwrap()
}

pub(crate) fn plan(source: &Path, dir: &Path, extra: &[&str]) -> Output {
    bin()
        .args(["sweep", "plan"])
        .arg(source)
        .arg("--out")
        .arg(dir)
        .args(["--backend", "cpu"])
        .args(extra)
        .output()
        .unwrap()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "exit {:?}\nstdout:\n{}\nstderr:\n{}", o.status.code(), stdout(o), stderr(o));
}

#[test]
fn a_sweep_runs_its_points_in_parallel_and_a_failed_point_does_not_stop_the_rest() {
    let dir = temp_dir("sweep_parallel");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, INVERSE).unwrap();
    let sw = dir.join("sw");
    ok(&plan(&script, &sw, &["--vary", "x=0,1,2,4", "--set", "offset=0.5"]));
    ok(&sweep(&["run", "--local", "-j", "2"], &sw));
    let status = sweep(&["status"], &sw);
    ok(&status);
    let text = stdout(&status);
    assert!(text.contains("4 point(s): 3 ok, 1 failed, 0 running, 0 interrupted, 0 pending"), "{text}");
    assert!(text.contains("run01 x=0: failed:") && text.contains("x must not be 0"), "{text}");
    ok(&sweep(&["collect"], &sw));
    let table = std::fs::read_to_string(sw.join("sweep.csv")).unwrap();
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines[0], "run,x,status,inverse,note", "{table}");
    assert!(lines[1].starts_with("run01,0,failed,,") && lines[1].contains("x must not be 0"), "{table}");
    assert_eq!(&lines[2..], ["run02,1,ok,1.5,", "run03,2,ok,1.0,", "run04,4,ok,0.75,"], "{table}");
    let timings = std::fs::read_to_string(sw.join("timings.csv")).unwrap();
    assert!(timings.starts_with("run,status,wall_s,host,started,finished\n"), "{timings}");
    for f in ["sweep.ron", "run01/log.txt", "run04/metrics.csv", "run04/run.ron", "outcomes/run01.ron"] {
        assert!(sw.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn finished_points_are_never_run_again_and_a_lost_one_reruns_alone() {
    let dir = temp_dir("sweep_resume_points");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, INVERSE).unwrap();
    let sw = dir.join("sw");
    ok(&plan(&script, &sw, &["--vary", "x=1,2,4", "--vary", "offset=0.0"]));
    ok(&sweep(&["run", "--local"], &sw));
    let first = std::fs::read(sw.join("outcomes/run01.ron")).unwrap();
    let again = sweep(&["run", "--local"], &sw);
    ok(&again);
    assert!(stderr(&again).contains("all 3 point(s) finished already"), "{}", stderr(&again));
    // A point whose outcome is lost (a node that died mid-run) is pending, and runs alone.
    std::fs::remove_file(sw.join("outcomes/run02.ron")).unwrap();
    let resumed = sweep(&["run", "--local", "-j", "2"], &sw);
    ok(&resumed);
    let err = stderr(&resumed);
    assert!(err.contains("1 point(s) to run, 1 at a time (2 finished already, skipped)"), "{err}");
    assert!(err.contains("run02 x=2 offset=0.0") && !err.contains("run01 x="), "{err}");
    assert_eq!(std::fs::read(sw.join("outcomes/run01.ron")).unwrap(), first, "run01 was run again");
    // Planning the same sweep again keeps what finished.
    ok(&plan(&script, &sw, &["--vary", "x=1,2,4", "--vary", "offset=0.0"]));
    assert_eq!(std::fs::read(sw.join("outcomes/run01.ron")).unwrap(), first);
}

#[test]
fn a_different_plan_in_the_folder_is_refused_unless_replaced() {
    let dir = temp_dir("sweep_replan");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, INVERSE).unwrap();
    let sw = dir.join("sw");
    ok(&plan(&script, &sw, &["--vary", "x=1,2", "--set", "offset=0"]));
    ok(&sweep(&["run", "--local"], &sw));
    let o = plan(&script, &sw, &["--vary", "x=1,3", "--set", "offset=0"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("holds a different sweep") && stderr(&o).contains("--replace"), "{}", stderr(&o));
    ok(&plan(&script, &sw, &["--vary", "x=1,3", "--set", "offset=0", "--replace"]));
    assert!(!sw.join("outcomes/run01.ron").exists(), "a replaced plan's outcomes must be forgotten");
}

#[test]
fn a_source_changed_after_planning_is_refused_before_any_point_runs() {
    let dir = temp_dir("sweep_changed");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, INVERSE).unwrap();
    let sw = dir.join("sw");
    ok(&plan(&script, &sw, &["--vary", "x=1,2", "--set", "offset=0"]));
    std::fs::write(&script, format!("{INVERSE}\nreport(\"extra\", 1);")).unwrap();
    let o = sweep(&["run", "--local"], &sw);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("has changed since the sweep was planned"), "{}", stderr(&o));
    assert!(!sw.join("outcomes").exists());
}

#[test]
fn runs_given_one_by_one_in_a_csv_file_are_the_points() {
    let dir = temp_dir("sweep_runs_csv");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, INVERSE).unwrap();
    std::fs::write(dir.join("design.csv"), "x,offset\n1,0\n2,1\n4,2\n").unwrap();
    let sw = dir.join("sw");
    ok(&bin()
        .args(["sweep", "plan"])
        .arg(&script)
        .arg("--out")
        .arg(&sw)
        .arg("--runs")
        .arg(dir.join("design.csv"))
        .args(["--backend", "cpu"])
        .output()
        .unwrap());
    ok(&sweep(&["run", "--local", "-j", "3"], &sw));
    ok(&sweep(&["collect"], &sw));
    let table = std::fs::read_to_string(sw.join("sweep.csv")).unwrap();
    assert_eq!(table, "run,x,offset,status,inverse,note\nrun01,1,0,ok,1.0,\nrun02,2,1,ok,1.5,\nrun03,4,2,ok,2.25,\n");
    let ron = std::fs::read_to_string(sw.join("sweep.ron")).unwrap();
    assert!(ron.contains("design.csv") && ron.contains("source_sha256"), "{ron}");
}

#[test]
fn the_slurm_job_array_lists_the_pending_points_and_the_chosen_resources() {
    let dir = temp_dir("sweep_sbatch");
    let script = dir.join("inverse.rhai");
    std::fs::write(&script, INVERSE).unwrap();
    let sw = dir.join("sw");
    ok(&plan(&script, &sw, &["--vary", "x=1,2,4,8", "--set", "offset=0"]));
    // Finish run02 here: the array holds the other three.
    let o = bin().args(["sweep", "point"]).arg(&sw).arg("1").output().unwrap();
    ok(&o);
    let o = bin()
        .args(["sweep", "slurm"])
        .arg(&sw)
        .args(["--partition", "short", "--time", "0:10:00", "--cpus-per-task", "2", "--max-parallel", "2"])
        .output()
        .unwrap();
    ok(&o);
    let text = std::fs::read_to_string(sw.join("sweep.sbatch")).unwrap();
    let abs = std::path::absolute(&sw).unwrap();
    for want in [
        "#SBATCH --array=0,2-3%2".to_string(),
        "#SBATCH --partition=short".to_string(),
        "#SBATCH --time=0:10:00".to_string(),
        "#SBATCH --cpus-per-task=2".to_string(),
        format!("#SBATCH --output={}/slurm/%A_%a.out", abs.display()),
        format!("sweep point '{}' \"$SLURM_ARRAY_TASK_ID\"", abs.display()),
    ] {
        assert!(text.contains(&want), "{want} missing from:\n{text}");
    }
    let bad = bin().args(["sweep", "slurm"]).arg(&sw).args(["--partition", "a\n#SBATCH --uid=0"]).output().unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("--partition"), "{}", stderr(&bad));
}

/// Settles a few dozen grains a little more with each `round`: 40 rounds last about a second.
const SETTLE: &str = r#"
let b = new_box("settle");
b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.006; b.ball_r = 0.4e-3; b.seed = params.seed;
let d = b.build_initial_model();
d.gravity = [0.0, 0.0, -9.81];
d.set_standard_dt();
for i in 0..params.rounds { d.balance("standard"); }
report("zmean", d.z.mean());
report("vmax", d.vz.abs().max());
"#;

#[test]
fn an_interrupted_sweep_resumes_and_ends_bit_for_bit_as_an_uninterrupted_one() {
    let dir = temp_dir("sweep_interrupt");
    let script = dir.join("settle.rhai");
    std::fs::write(&script, SETTLE).unwrap();
    let (cut, whole) = (dir.join("cut"), dir.join("whole"));
    for sw in [&cut, &whole] {
        ok(&plan(&script, sw, &["--vary", "seed=1,2,3", "--set", "rounds=40"]));
    }
    let child = bin().args(["sweep", "run", "--local"]).arg(&cut).stderr(std::process::Stdio::piped()).spawn().unwrap();
    let start = std::time::Instant::now();
    // Stop it once run02 has begun (run01 finished, run02's run record written).
    while !(cut.join("outcomes/run01.ron").exists() && cut.join("run02/run.ron").exists()) {
        assert!(start.elapsed().as_secs() < 120, "run02 never started");
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    std::thread::sleep(std::time::Duration::from_millis(100));
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(stderr(&o).contains("interrupted: "), "{}", stderr(&o));
    let first = std::fs::read(cut.join("outcomes/run01.ron")).unwrap();
    // Under load the second point may have finished or the third begun: some point is left.
    let status = stdout(&sweep(&["status"], &cut));
    assert!(status.contains("3 point(s): ") && !status.contains("3 ok"), "{status}");
    let resumed = sweep(&["run", "--local"], &cut);
    ok(&resumed);
    assert!(stderr(&resumed).contains("finished already, skipped)"), "{}", stderr(&resumed));
    assert_eq!(std::fs::read(cut.join("outcomes/run01.ron")).unwrap(), first, "run01 was run again");
    ok(&sweep(&["run", "--local", "-j", "2"], &whole));
    for sw in [&cut, &whole] {
        ok(&sweep(&["collect"], sw));
    }
    let (a, b) = (std::fs::read(cut.join("sweep.csv")).unwrap(), std::fs::read(whole.join("sweep.csv")).unwrap());
    assert_eq!(String::from_utf8_lossy(&a), String::from_utf8_lossy(&b));
    assert!(String::from_utf8_lossy(&a).lines().skip(1).all(|l| l.contains(",ok,")), "{}", String::from_utf8_lossy(&a));
}
