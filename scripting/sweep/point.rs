//! One point of a sweep: its `matdem-rs run` as a child process in the point's run folder,
//! timed, its output kept in `log.txt`, and how it ended written to `outcomes/NAME.ron`.
//! The same function runs a point for `sweep run --local` and for a Slurm array task.

use super::plan::SweepPlan;
use matdem_engine::backend::RunControl;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// A point's output (stdout, then stderr) in its run folder, which the sandbox keeps for
/// the host.
pub use crate::sandbox::LOG_FILE;

/// The folder of outcomes at the top of the sweep folder.
pub const OUTCOMES_DIR: &str = "outcomes";

/// How a point's run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PointStatus {
    /// The run exited 0.
    Ok,
    /// The run failed; `error` says why. The sweep goes on without it.
    Failed,
    /// Stopped by Ctrl-C, SIGTERM or a scheduler's time limit; the next run resumes it.
    Interrupted,
}

/// `outcomes/NAME.ron`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    pub status: PointStatus,
    /// The first error line of the run, for a failed point.
    pub error: Option<String>,
    pub exit_code: Option<i32>,
    pub wall_s: f64,
    /// The machine that ran it.
    pub host: String,
    /// UTC, RFC 3339.
    pub started: String,
    pub finished: String,
}

pub fn outcome_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(OUTCOMES_DIR).join(format!("{name}.ron"))
}

/// The recorded outcome of point `name`; `None` when it has none yet.
pub fn read_outcome(dir: &Path, name: &str) -> Result<Option<Outcome>, String> {
    let path = outcome_path(dir, name);
    // Not through a link leading out of the sweep folder (a received folder is untrusted).
    crate::sandbox::output_path(dir, &format!("{OUTCOMES_DIR}/{name}.ron"))?;
    let outcome: Outcome = match std::fs::read_to_string(&path) {
        Ok(text) => ron::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("cannot read {}: {e}", path.display())),
    };
    Ok(Some(finished_by_hand(dir, name, outcome)))
}

/// An interrupted point that a user resumed by hand (`matdem-rs run … --resume DIR/runNN`) and
/// that finished: its run.ron says so, and the point is done (not rerun from scratch).
fn finished_by_hand(dir: &Path, name: &str, outcome: Outcome) -> Outcome {
    #[derive(Deserialize)]
    struct Record {
        status: String,
        finished: Option<String>,
        resumed_from: Option<String>,
    }
    if outcome.status != PointStatus::Interrupted {
        return outcome;
    }
    let Ok(path) = crate::sandbox::output_path(dir, &format!("{name}/{}", crate::run_record::RUN_RECORD)) else {
        return outcome;
    };
    match std::fs::read_to_string(path).ok().and_then(|t| ron::from_str::<Record>(&t).ok()) {
        Some(r) if r.status == "ok" && r.resumed_from.is_some() => Outcome {
            status: PointStatus::Ok,
            exit_code: Some(0),
            finished: r.finished.unwrap_or(outcome.finished.clone()),
            ..outcome
        },
        _ => outcome,
    }
}

/// Whether point `name` still has to run: no outcome, an interrupted one, or (when asked)
/// a failed one.
pub fn is_pending(dir: &Path, name: &str, retry_failed: bool) -> Result<bool, String> {
    Ok(match read_outcome(dir, name)? {
        None => true,
        Some(o) => match o.status {
            PointStatus::Ok => false,
            PointStatus::Failed => retry_failed,
            PointStatus::Interrupted => true,
        },
    })
}

/// Checks that the source is still what the sweep was planned with.
pub fn check_source(plan: &SweepPlan) -> Result<(), String> {
    let now = super::digest::source_sha256(&plan.source)?;
    if now != plan.source_sha256 {
        return Err(format!(
            "{} has changed since the sweep was planned (SHA-256 {} then, {} now): the points would not run the \
             same code. Plan a new sweep (or `sweep plan --replace` over this one)",
            plan.source.display(),
            short(&plan.source_sha256),
            short(&now)
        ));
    }
    Ok(())
}

fn short(sha: &str) -> &str {
    &sha[..sha.len().min(12)]
}

/// What became of a point asked to run.
#[derive(Debug, Clone, PartialEq)]
pub enum PointRun {
    /// It ran; how it ended is recorded in `outcomes/NAME.ron`.
    Ran(Outcome),
    /// Another process runs it now (its folder is locked): left alone, nothing recorded, its
    /// log untouched.
    Busy,
}

/// Runs point `index` of the sweep in `dir` with the `matdem-rs` at `exe` and records its
/// outcome. `threads` (if given) becomes the run's RAYON_NUM_THREADS. Errors are the
/// sweep's own (a folder it cannot write), not the point's: those are in the outcome.
pub fn run_point(
    dir: &Path,
    plan: &SweepPlan,
    index: usize,
    exe: &Path,
    threads: Option<usize>,
    control: &RunControl,
) -> Result<PointRun, String> {
    let point = &plan.points[index];
    let run_dir = crate::sandbox::output_path(dir, &point.name)?;
    if super::collect::is_locked(&run_dir) {
        return Ok(PointRun::Busy);
    }
    let resume = matches!(read_outcome(dir, &point.name)?, Some(Outcome { status: PointStatus::Interrupted, .. }))
        && crate::resume::resume_dir(&run_dir).join(crate::resume::JOURNAL_FILE).is_file();
    let mut cmd = Command::new(exe);
    cmd.arg("run").arg(&plan.source).arg("--out").arg(&run_dir);
    let mut backend = plan.backend.clone();
    if resume {
        // A resumed run keeps the parameters of its first start (its run.ron).
        cmd.arg("--resume").arg(&run_dir);
    }
    let mut set = Vec::new();
    for (name, value) in point.parameters.iter().chain(&plan.fixed) {
        // The backend is a command-line choice, not a script parameter.
        if name == "backend" {
            backend = value.clone();
        } else if !resume {
            set.push((name.clone(), value.clone()));
        }
    }
    // Through a file beside the point's folder: a value may be longer than one argument can
    // be (128 kB), and a value can never be read as an option.
    let set_file = dir.join(format!(".{}.set.ron", point.name));
    let _removed = RemoveOnDrop(&set_file);
    if !set.is_empty() {
        let text = ron::to_string(&set).map_err(|e| format!("cannot write the parameters of {}: {e}", point.name))?;
        crate::atomic_write::write(&set_file, text.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", set_file.display()))?;
        cmd.arg("--set-file").arg(&set_file);
    }
    cmd.arg(format!("--backend={backend}"));
    if let Some(n) = threads {
        cmd.env("RAYON_NUM_THREADS", n.to_string());
    }
    // A stale metrics file from an earlier attempt must not pass for this run's.
    if !resume {
        let _ = std::fs::remove_file(run_dir.join(crate::metrics::METRICS_FILE));
    }
    let started = crate::run_record::now_utc();
    let clock = Instant::now();
    let (status, stdout, stderr) = match run_until_cancelled(cmd, control, &run_dir) {
        Ok(ended) => ended,
        // The point could not start (too many processes, a binary gone): that point failed,
        // the sweep goes on.
        Err(why) if why.starts_with(NOT_STARTED) => {
            let outcome = Outcome {
                status: PointStatus::Failed,
                error: Some(why),
                exit_code: None,
                wall_s: clock.elapsed().as_secs_f64(),
                host: hostname(),
                started,
                finished: crate::run_record::now_utc(),
            };
            return record(dir, &point.name, outcome);
        }
        Err(why) => return Err(why),
    };
    let wall_s = clock.elapsed().as_secs_f64();
    // Locked between the check above and the child's start: the holder's log and outcome
    // are its own.
    if status.code() == Some(2) && String::from_utf8_lossy(&stderr).contains(crate::out_lock::IN_USE) {
        return Ok(PointRun::Busy);
    }
    let mut log = stdout;
    log.extend_from_slice(&stderr);
    let log_path = run_dir.join(LOG_FILE);
    crate::atomic_write::write(&log_path, &log).map_err(|e| format!("cannot write {}: {e}", log_path.display()))?;
    let code = status.code();
    let (status_kind, error) = match code {
        Some(0) => (PointStatus::Ok, None),
        // 130: the run saved what a resume needs (or stopped where it could not).
        Some(130) => (PointStatus::Interrupted, None),
        None if control.is_cancelled() => (PointStatus::Interrupted, None),
        _ => (PointStatus::Failed, Some(first_error_line(&String::from_utf8_lossy(&stderr), code))),
    };
    let outcome = Outcome {
        status: status_kind,
        error,
        exit_code: code,
        wall_s,
        host: hostname(),
        started,
        finished: crate::run_record::now_utc(),
    };
    record(dir, &point.name, outcome)
}

/// Writes `outcomes/NAME.ron`.
fn record(dir: &Path, name: &str, outcome: Outcome) -> Result<PointRun, String> {
    let text = ron::ser::to_string_pretty(&outcome, ron::ser::PrettyConfig::default())
        .map_err(|e| format!("cannot write the outcome of {name}: {e}"))?;
    let path = outcome_path(dir, name);
    crate::atomic_write::write(&path, text.as_bytes()).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(PointRun::Ran(outcome))
}

struct RemoveOnDrop<'a>(&'a Path);

impl Drop for RemoveOnDrop<'_> {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(self.0);
    }
}

/// How [`run_until_cancelled`]'s error begins when the child never started.
const NOT_STARTED: &str = "cannot start";

fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname").map_or_else(|_| "unknown".into(), |h| h.trim().to_string())
}

/// Runs `cmd` to its end, its output caught in files beside `dir`; when `control` is
/// cancelled, sends the child SIGTERM (so it saves its resume point) and waits for it.
pub fn run_until_cancelled(
    mut cmd: Command,
    control: &RunControl,
    dir: &Path,
) -> Result<(std::process::ExitStatus, Vec<u8>, Vec<u8>), String> {
    let parent = dir.parent().unwrap_or(Path::new("."));
    let name = dir.file_name().unwrap_or_default().to_string_lossy();
    let (out_path, err_path) = (parent.join(format!(".{name}.stdout")), parent.join(format!(".{name}.stderr")));
    let file = |p: &Path| std::fs::File::create(p).map_err(|e| format!("cannot create {}: {e}", p.display()));
    cmd.stdout(file(&out_path)?).stderr(file(&err_path)?).stdin(std::process::Stdio::null());
    let mut child = cmd.spawn().map_err(|e| format!("{NOT_STARTED} {:?}: {e}", cmd.get_program()))?;
    let mut told = false;
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) => {}
            Err(e) => return Err(format!("cannot wait for run {}: {e}", dir.display())),
        }
        if control.is_cancelled() && !told {
            // SAFETY: kill(2) on our own child's pid; no memory is touched.
            unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) };
            told = true;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let read = |p: &Path| {
        let bytes = std::fs::read(p).unwrap_or_default();
        let _ = std::fs::remove_file(p);
        bytes
    };
    Ok((status, read(&out_path), read(&err_path)))
}

/// The run's first `error…` line, with its exit code.
pub fn first_error_line(stderr: &str, code: Option<i32>) -> String {
    let line = stderr.lines().find(|l| l.starts_with("error")).unwrap_or("the run failed").trim();
    match code {
        Some(c) => format!("{line} (exit {c})"),
        None => format!("{line} (killed)"),
    }
}
