//! `sweep run DIR --local -j N`: the pending points of a sweep, N child processes at a time
//! on this machine. Finished points are skipped; a failed point is recorded and the others
//! go on; Ctrl-C stops the running points so that they resume on the next run.

use super::plan::SweepPlan;
use super::point::{check_source, is_pending, run_point, Outcome, PointRun, PointStatus};
use matdem_engine::backend::RunControl;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

#[derive(Clone)]
pub struct LocalOptions {
    /// Points run at once.
    pub jobs: usize,
    /// Rerun points that failed before (by default a failed point stays failed).
    pub retry_failed: bool,
    /// The `matdem-rs` binary that runs each point.
    pub exe: PathBuf,
    pub control: RunControl,
}

/// What a local run did.
#[derive(Debug, Default)]
pub struct LocalSummary {
    /// Points that were finished already and skipped.
    pub skipped: usize,
    /// `(index, outcome)` of every point run now, in the order they finished.
    pub ran: Vec<(usize, Outcome)>,
}

/// Runs the sweep's pending points; `progress` hears one line per point that finishes.
/// Holds the sweep folder's lock, so two local runs of one sweep cannot interleave.
pub fn run_local(
    dir: &Path,
    plan: &SweepPlan,
    opts: &LocalOptions,
    progress: impl Fn(&str) + Sync,
) -> Result<LocalSummary, String> {
    check_options(opts)?;
    let lock = crate::out_lock::OutLock::acquire(dir, &format!("sweep run {}", dir.display()))?;
    run_local_held(&lock, plan, opts, progress)
}

fn check_options(opts: &LocalOptions) -> Result<(), String> {
    if opts.jobs == 0 {
        return Err("-j 0 would run nothing; give at least 1".into());
    }
    Ok(())
}

/// [`run_local`] in the folder `held` locks (a study, which planned it under the same lock).
pub fn run_local_held(
    held: &crate::out_lock::OutLock,
    plan: &SweepPlan,
    opts: &LocalOptions,
    progress: impl Fn(&str) + Sync,
) -> Result<LocalSummary, String> {
    check_options(opts)?;
    let dir = held.dir();
    check_source(plan)?;
    let mut pending = Vec::new();
    for (k, p) in plan.points.iter().enumerate() {
        if is_pending(dir, &p.name, opts.retry_failed)? {
            pending.push(k);
        }
    }
    let skipped = plan.points.len() - pending.len();
    if pending.is_empty() {
        progress(&format!("sweep: all {} point(s) finished already; nothing to run", plan.points.len()));
        return Ok(LocalSummary { skipped, ran: vec![] });
    }
    let jobs = opts.jobs.min(pending.len());
    // Child processes share the cores: each gets its share of threads, unless the caller chose.
    let threads = match std::env::var_os("RAYON_NUM_THREADS") {
        Some(_) => None,
        None => Some((std::thread::available_parallelism().map_or(1, |n| n.get()) / jobs).max(1)),
    };
    progress(&format!(
        "sweep: {} point(s) to run, {jobs} at a time{}",
        pending.len(),
        if skipped > 0 { format!(" ({skipped} finished already, skipped)") } else { String::new() }
    ));
    let next = AtomicUsize::new(0);
    let ran = Mutex::new(Vec::new());
    let failure = Mutex::new(None::<String>);
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| loop {
                if opts.control.is_cancelled() || failure.lock().unwrap().is_some() {
                    return;
                }
                let Some(&k) = pending.get(next.fetch_add(1, Ordering::SeqCst)) else { return };
                match run_point(dir, plan, k, &opts.exe, threads, &opts.control) {
                    Ok(PointRun::Ran(outcome)) => {
                        progress(&line(plan, k, &outcome));
                        ran.lock().unwrap().push((k, outcome));
                    }
                    Ok(PointRun::Busy) => {
                        progress(&format!("{} is running in another process; left alone", plan.points[k].name))
                    }
                    Err(e) => {
                        failure.lock().unwrap().get_or_insert(e);
                        return;
                    }
                }
            });
        }
    });
    if let Some(e) = failure.into_inner().unwrap() {
        return Err(e);
    }
    let ran = ran.into_inner().unwrap();
    if opts.control.is_cancelled() {
        let done = plan.points.iter().filter(|p| !is_pending(dir, &p.name, true).unwrap_or(true)).count();
        return Err(format!(
            "interrupted: {done} of {} point(s) finished and are kept; run `matdem-rs sweep run {} --local` again \
             to finish the rest (interrupted points resume where they stopped)",
            plan.points.len(),
            dir.display()
        ));
    }
    Ok(LocalSummary { skipped, ran })
}

/// The progress line of a finished point, for a terminal: its values and error escaped.
fn line(plan: &SweepPlan, k: usize, o: &Outcome) -> String {
    use crate::terminal_text::one_line;
    let p = &plan.points[k];
    let setting = one_line(&super::collect::setting_text(&p.parameters)).into_owned();
    let how = match o.status {
        PointStatus::Ok => "ok".to_string(),
        PointStatus::Failed => format!("failed: {}", one_line(o.error.as_deref().unwrap_or("?"))),
        PointStatus::Interrupted => "interrupted (resumes on the next run)".to_string(),
    };
    format!("{} {setting}  {:.1} s, {how}", p.name, o.wall_s)
}
