//! Hardening II (issue 28), what a received folder can do to the host and what every writer
//! owes the folder lock: a planted lock link, a linked sweep point, writers beside a running
//! run, a busy point, edited resume files, long parameter values and oversized packages.
//! Each test names the failure it saw on the code before its fix.

use crate::common::*;
use crate::sweep_cli::{plan as sweep_plan, sweep};
use matdem_rs::out_lock::OutLock;
use std::io::Read;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const REPORT: &str = r#"report("m", params.x * 2.0);"#;

fn ok(o: &Output) {
    assert!(o.status.success(), "exit {:?}\nstdout:\n{}\nstderr:\n{}", o.status.code(), stdout(o), stderr(o));
}

/// A precious file outside the run and a lock file in `out` that links to it.
fn plant_lock_link(dir: &Path, out: &Path) -> std::path::PathBuf {
    let precious = dir.join("bashrc");
    std::fs::write(&precious, "export PATH=precious\n").unwrap();
    std::fs::create_dir_all(out).unwrap();
    std::os::unix::fs::symlink(&precious, out.join(".matdem-rs.lock")).unwrap();
    precious
}

// Before: `run --out o/x` truncated ~/.bashrc through the planted link and wrote
// "matdem-rs pid N (run …)" into it; so did repl, study and sweep run.
#[test]
fn a_lock_file_planted_as_a_link_is_refused_by_every_command_and_its_target_untouched() {
    let dir = temp_dir("lock_link");
    let script = dir.join("w.rhai");
    std::fs::write(&script, REPORT).unwrap();
    let check = |what: &str, o: &Output, precious: &Path| {
        assert!(!o.status.success(), "{what} ran through the planted link: {}", stderr(o));
        assert!(stderr(o).contains("symbolic link"), "{what}: {}", stderr(o));
        assert_eq!(std::fs::read_to_string(precious).unwrap(), "export PATH=precious\n", "{what} wrote through it");
    };
    let out = dir.join("o/run");
    let precious = plant_lock_link(&dir, &out);
    let o = bin().arg("run").arg(&script).arg("--out").arg(&out).args(["--set", "x=1"]).output().unwrap();
    check("run", &o, &precious);
    assert!(!out.join("run.ron").exists(), "the refused run wrote its record");

    let out = dir.join("o/repl");
    std::os::unix::fs::symlink(&precious, {
        std::fs::create_dir_all(&out).unwrap();
        out.join(".matdem-rs.lock")
    })
    .unwrap();
    let o = bin().arg("repl").arg("--out").arg(&out).stdin(Stdio::null()).output().unwrap();
    check("repl", &o, &precious);

    let out = dir.join("o/study");
    std::fs::create_dir_all(&out).unwrap();
    std::os::unix::fs::symlink(&precious, out.join(".matdem-rs.lock")).unwrap();
    let o = bin()
        .arg("study")
        .arg(&script)
        .args(["--vary", "x=1,2", "--metric", "m", "--backend", "cpu", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    check("study", &o, &precious);
    assert!(!out.join("sweep.ron").exists(), "the refused study planned into the folder");

    let sw = dir.join("o/sweep");
    ok(&sweep_plan(&script, &sw, &["--vary", "x=1,2"]));
    std::os::unix::fs::symlink(&precious, sw.join(".matdem-rs.lock")).unwrap();
    check("sweep run", &sweep(&["run", "--local"], &sw), &precious);
}

// Before: `sweep collect` followed `run01 -> /elsewhere` and merged its metrics.csv (999).
#[test]
fn sweep_collect_refuses_a_point_folder_linked_out_of_the_sweep() {
    let dir = temp_dir("collect_link");
    let script = dir.join("w.rhai");
    std::fs::write(&script, REPORT).unwrap();
    let sw = dir.join("sw");
    ok(&sweep_plan(&script, &sw, &["--vary", "x=1,2"]));
    ok(&sweep(&["run", "--local", "-j", "1"], &sw));
    let elsewhere = dir.join("elsewhere");
    std::fs::rename(sw.join("run01"), &elsewhere).unwrap();
    std::fs::write(elsewhere.join("metrics.csv"), "name,value\nm,999\n").unwrap();
    std::os::unix::fs::symlink(&elsewhere, sw.join("run01")).unwrap();
    let _ = std::fs::remove_file(sw.join("sweep.csv"));
    for action in ["collect", "status"] {
        let o = sweep(&[action], &sw);
        assert!(!o.status.success(), "{action} followed the link: {}", stdout(&o));
        assert!(stderr(&o).contains("run01") && stderr(&o).contains("symbolic link"), "{action}: {}", stderr(&o));
    }
    assert!(!sw.join("sweep.csv").exists(), "collect merged the linked point");
}

// Before: while `run --out o/L` ran, `sweep plan --out o/L` wrote sweep.ron and run01/ into
// it, `study --out o/L` wrote sweep.ron and then refused, and `sweep plan --replace` swapped
// the plan of a running sweep; `plan` wrote tables and models into ./out/plan.
#[test]
fn no_writer_touches_a_folder_another_process_holds_and_plan_writes_nothing() {
    let dir = temp_dir("writers_lock");
    let script = dir.join("w.rhai");
    std::fs::write(&script, REPORT).unwrap();
    let held = dir.join("L");
    let lock = OutLock::acquire(&held, "run w.rhai").unwrap();
    let o = sweep_plan(&script, &held, &["--vary", "x=1,2"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("is in use by") && stderr(&o).contains("run w.rhai"), "{}", stderr(&o));
    let o = bin()
        .arg("study")
        .arg(&script)
        .args(["--vary", "x=1,2", "--metric", "m", "--backend", "cpu", "--out"])
        .arg(&held)
        .output()
        .unwrap();
    assert!(!o.status.success() && stderr(&o).contains("is in use by"), "{}", stderr(&o));
    let left: Vec<_> = std::fs::read_dir(&held).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, [".matdem-rs.lock"], "a refused writer left files in the held folder");
    drop(lock);

    // A running sweep's plan cannot be replaced under it (its folder is held).
    let sw = dir.join("sw");
    ok(&sweep_plan(&script, &sw, &["--vary", "x=1,2"]));
    let before = std::fs::read(sw.join("sweep.ron")).unwrap();
    let lock = OutLock::acquire(&sw, "sweep run sw").unwrap();
    let o = sweep_plan(&script, &sw, &["--vary", "x=5,6", "--replace"]);
    assert!(!o.status.success() && stderr(&o).contains("is in use by"), "{}", stderr(&o));
    assert_eq!(std::fs::read(sw.join("sweep.ron")).unwrap(), before, "the plan was swapped under the sweep");
    drop(lock);

    // `plan` runs the script to its first step but leaves nothing behind.
    let scene = dir.join("scene.rhai");
    std::fs::write(
        &scene,
        format!("{SMALL_BOX}\nd.record(#{{ a: 1.0 }}); d.status.save(\"t\"); d.save(\"m\"); d.run(10);"),
    )
    .unwrap();
    let o = bin().current_dir(&dir).arg("plan").arg(&scene).output().unwrap();
    ok(&o);
    assert!(!dir.join("out").exists(), "plan wrote {:?}", std::fs::read_dir(dir.join("out")).map(|d| d.count()));
}

// Before: `sweep point S 0` while point 0 ran recorded it `Failed` ("in use") and replaced its
// log.txt with the refusal, losing the running point's log.
#[test]
fn a_point_another_process_runs_is_left_alone_and_its_log_kept() {
    let dir = temp_dir("busy_point");
    let script = dir.join("w.rhai");
    std::fs::write(&script, REPORT).unwrap();
    let sw = dir.join("sw");
    ok(&sweep_plan(&script, &sw, &["--vary", "x=1,2"]));
    let busy = OutLock::acquire(&sw.join("run01"), "run w.rhai (the real point)").unwrap();
    std::fs::write(sw.join("run01/log.txt"), "the real run's log\n").unwrap();
    let o = bin().args(["sweep", "point"]).arg(&sw).arg("0").output().unwrap();
    ok(&o);
    assert!(stderr(&o).contains("run01 is running in another process; left alone"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(sw.join("run01/log.txt")).unwrap(), "the real run's log\n");
    assert!(!sw.join("outcomes/run01.ron").exists(), "a busy point was given an outcome");
    let o = sweep(&["status"], &sw);
    assert!(stdout(&o).contains("1 running"), "{}", stdout(&o));
    drop(busy);
    ok(&bin().args(["sweep", "point"]).arg(&sw).arg("0").output().unwrap());
    assert!(std::fs::read_to_string(sw.join("outcomes/run01.ron")).unwrap().contains("Ok"));
}

/// A tiny box that runs long enough to be interrupted once its first table is written.
const LONG: &str = r#"
let b = new_box("tiny");
b.ball_r = 0.5e-3; b.distri_rate = 0.2;
b.sample_w = 4e-3; b.sample_l = 4e-3; b.sample_h = 5e-3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, r: 0.5e-3, mu_p: 0.5 }));
d.set_standard_dt();
d.gravity = [0.0, 0.0, -9.81];
d.run(200);
d.record(#{ z: d.z.mean() });
d.status.save("first.csv");
d.run(50000000);
d.status.save("last.csv");
"#;

/// Runs `script` into `out` and interrupts it with SIGTERM once `first.csv` is written.
fn interrupted_run(script: &Path, out: &Path) {
    let mut child = bin()
        .arg("run")
        .arg(script)
        .arg("--out")
        .arg(out)
        .args(["--backend", "cpu"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !out.join("first.csv").exists() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("the run never wrote its first table");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(200));
    assert!(Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap().success());
    let status = child.wait().unwrap();
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
}

fn resume(script: &Path, out: &Path) -> Output {
    bin().arg("run").arg(script).arg("--resume").arg(out).args(["--backend", "cpu"]).output().unwrap()
}

/// Seals `out`'s (edited) journal in its run.ron, as a user who knew of the seal would.
fn reseal(out: &Path) {
    let journal = std::fs::read(out.join("resume/journal.ron")).unwrap();
    let sha = matdem_rs::run_record::sha256_hex(&journal);
    let record = std::fs::read_to_string(out.join("run.ron")).unwrap();
    let start = record.find("resume_journal_sha256: Some(\"").unwrap() + "resume_journal_sha256: Some(\"".len();
    let record = format!("{}{sha}{}", &record[..start], &record[start + 64..]);
    std::fs::write(out.join("run.ron"), record).unwrap();
}

// Before: `done:` raised past the call's steps in journal.ron finished early with another
// result; another run's model_0.mdem (valid CRC) was continued; `Steps(…)` raised to
// i64::MAX ran forever. Each is refused now, and the untouched folder still resumes.
#[test]
fn edited_resume_files_are_refused_and_the_untouched_folder_still_resumes() {
    let dir = temp_dir("resume_seal");
    let script = dir.join("long.rhai");
    std::fs::write(&script, LONG).unwrap();
    let out = dir.join("cut");
    interrupted_run(&script, &out);
    let journal_path = out.join("resume/journal.ron");
    let journal = std::fs::read_to_string(&journal_path).unwrap();
    let record = std::fs::read_to_string(out.join("run.ron")).unwrap();
    assert!(record.contains("resume_journal_sha256: Some(\""), "{record}");
    let refused = |what: &str, needle: &str| {
        let o = resume(&script, &out);
        assert!(matches!(o.status.code(), Some(1 | 2)), "{what} was resumed: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{what}: {}", stderr(&o));
    };

    let done = journal.find("done: ").unwrap() + "done: ".len();
    let end = done + journal[done..].find(',').unwrap();
    let edited = format!("{}60000000{}", &journal[..done], &journal[end..]);
    std::fs::write(&journal_path, &edited).unwrap();
    refused("an edited journal", "is not the journal its run.ron seals");
    reseal(&out);
    refused("a journal whose `done` passes its steps", "did 60000000 of 50000000 step(s)");

    std::fs::write(&journal_path, journal.replace("Steps(50000000)", "Steps(9223372036854775807)")).unwrap();
    reseal(&out);
    refused("a journal whose steps were raised", "the interrupted run's was Steps(9223372036854775807)");

    std::fs::write(&journal_path, &journal).unwrap();
    reseal(&out);
    let model = std::fs::read(out.join("resume/model_0.mdem")).unwrap();
    let other = dir.join("other.rhai");
    std::fs::write(&other, LONG.replace("b.sample_h = 5e-3", "b.sample_h = 6e-3")).unwrap();
    let other_out = dir.join("other");
    interrupted_run(&other, &other_out);
    std::fs::copy(other_out.join("resume/model_0.mdem"), out.join("resume/model_0.mdem")).unwrap();
    refused("another run's model", "is not the model its journal names");

    std::fs::write(out.join("resume/model_0.mdem"), model).unwrap();
    // Continues (and is stopped again: 50 M steps is not for a test).
    let mut child = bin()
        .arg("run")
        .arg(&script)
        .arg("--resume")
        .arg(&out)
        .args(["--backend", "cpu"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    assert!(child.try_wait().unwrap().is_none(), "the untouched resume folder was refused");
    assert!(Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap().success());
    assert_eq!(child.wait().unwrap().code(), Some(130));
}

// Before: a 200 kB value in `--runs` stopped the whole sweep ("Argument list too long") with
// nothing recorded.
#[test]
fn a_parameter_value_longer_than_a_command_line_reaches_its_point() {
    let dir = temp_dir("long_value");
    let script = dir.join("w.rhai");
    std::fs::write(&script, r#"report("len", params.s.len().to_float());"#).unwrap();
    let long = "a".repeat(200_000);
    std::fs::write(dir.join("runs.csv"), format!("s\n{long}\nb\n")).unwrap();
    let sw = dir.join("sw");
    let runs = dir.join("runs.csv");
    ok(&sweep_plan(&script, &sw, &["--runs", runs.to_str().unwrap()]));
    ok(&sweep(&["run", "--local", "-j", "1"], &sw));
    ok(&sweep(&["collect"], &sw));
    let table = std::fs::read_to_string(sw.join("sweep.csv")).unwrap();
    assert!(table.contains(",ok,200000.0,") && table.contains("run02,b,ok,1.0,"), "{}", &table[table.len() - 80..]);
    assert!(!std::fs::read_dir(&sw).unwrap().any(|e| e.unwrap().file_name().to_string_lossy().ends_with(".set.ron")));
}

// Before: `pack` wrote a 556 MB archive that `run` and `info` then refused (512 MiB limit).
#[test]
fn pack_refuses_what_run_would_refuse_before_writing() {
    let dir = temp_dir("pack_limit");
    let pkg = dir.join("pkg");
    std::fs::create_dir_all(&pkg).unwrap();
    std::fs::write(pkg.join("main.rhai"), "print(1);").unwrap();
    std::fs::write(
        pkg.join("simulator.ron"),
        "(name: \"big\", version: \"1.0.0\", description: \"too big\", entry: \"main.rhai\", parameters: [], \
         outputs: [])",
    )
    .unwrap();
    // Sparse: 513 MiB of size, no disk.
    std::fs::File::create(pkg.join("dump.bin")).unwrap().set_len(513 << 20).unwrap();
    let tar = dir.join("big.tar");
    let o = bin().arg("pack").arg(&pkg).arg("-o").arg(&tar).output().unwrap();
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("more than 536870912 bytes") && stderr(&o).contains("dump.bin"), "{}", stderr(&o));
    assert!(!tar.exists());
}

// Before: after a point was resumed by hand and finished, `sweep status` still said
// `interrupted` and `sweep point` ran it again from scratch.
#[test]
fn a_point_resumed_by_hand_and_finished_counts_as_done() {
    let dir = temp_dir("resumed_by_hand");
    let script = dir.join("w.rhai");
    std::fs::write(&script, REPORT).unwrap();
    let sw = dir.join("sw");
    ok(&sweep_plan(&script, &sw, &["--vary", "x=1,2"]));
    std::fs::create_dir_all(sw.join("outcomes")).unwrap();
    std::fs::write(
        sw.join("outcomes/run01.ron"),
        "(status: Interrupted, error: None, exit_code: Some(130), wall_s: 1.0, host: \"h\", started: \
         \"2026-12-04T00:00:00Z\", finished: \"2026-12-04T00:00:01Z\")",
    )
    .unwrap();
    // What `matdem-rs run w.rhai --resume sw/run01` leaves when it finishes.
    std::fs::write(
        sw.join("run01/run.ron"),
        "(script: \"w.rhai\", script_sha256: \"x\", parameters: [], backend: \"cpu (f64)\", matdem_rs_version: \
         \"0.1.0\", started: \"2026-12-04T00:01:00Z\", finished: Some(\"2026-12-04T00:02:00Z\"), status: \"ok\", \
         exit_code: Some(0), resumed_from: Some(\"sw/run01\"))",
    )
    .unwrap();
    std::fs::write(sw.join("run01/metrics.csv"), "name,value\nm,2.0\n").unwrap();
    let o = sweep(&["status"], &sw);
    assert!(stdout(&o).contains("2 point(s): 1 ok, 0 failed, 0 running, 0 interrupted, 1 pending"), "{}", stdout(&o));
    let o = bin().args(["sweep", "point"]).arg(&sw).arg("0").output().unwrap();
    assert!(stderr(&o).contains("run01 finished already; skipped"), "{}", stderr(&o));
}
