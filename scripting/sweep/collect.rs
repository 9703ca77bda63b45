//! `sweep status` and `sweep collect`: what each point's folder says — finished, failed with
//! its error, running, interrupted or pending — and the merged table of every point's
//! parameters and metrics. Read from the sweep folder alone, wherever the points ran.

use super::plan::SweepPlan;
use super::point::{read_outcome, PointStatus, LOG_FILE};
use crate::metrics::{parse_metrics, METRICS_FILE};
use crate::terminal_text::one_line;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The merged table's file name; `timings.csv` holds what differs from machine to machine.
pub const TABLE_FILE: &str = "sweep.csv";
pub const TIMINGS_FILE: &str = "timings.csv";

/// The merged table's own columns besides parameters and metrics: a parameter may not take
/// one of these names (the plan refuses it), a metric that does is prefixed.
pub const OWN_COLUMNS: [&str; 3] = ["run", "status", "note"];

/// A metric's column in the merged table: `metric:NAME` where NAME is one of the table's own
/// columns or a parameter's, so that every header names one column. Metric names are words
/// (`report` checks them), so the prefixed name cannot be another metric's.
pub fn metric_column(name: &str, params: &[impl AsRef<str>]) -> String {
    if OWN_COLUMNS.contains(&name) || params.iter().any(|p| p.as_ref() == name) {
        format!("metric:{name}")
    } else {
        name.to_string()
    }
}

/// Where a point stands.
#[derive(Debug, Clone, PartialEq)]
pub enum PointState {
    Pending,
    /// Its run holds its folder's lock now.
    Running,
    Ok,
    Failed(String),
    Interrupted,
}

impl PointState {
    pub fn label(&self) -> &'static str {
        match self {
            PointState::Pending => "pending",
            PointState::Running => "running",
            PointState::Ok => "ok",
            PointState::Failed(_) => "failed",
            PointState::Interrupted => "interrupted",
        }
    }
}

/// One point as its folder tells it.
#[derive(Debug, Clone)]
pub struct PointResult {
    pub name: String,
    pub parameters: Vec<(String, String)>,
    pub state: PointState,
    /// What the run reported with `report(name, value)`, in the order first reported.
    pub metrics: Vec<(String, f64)>,
    /// Why a finished run's metrics could not be read, if so.
    pub metrics_error: Option<String>,
    pub wall_s: Option<f64>,
    pub host: Option<String>,
    pub started: Option<String>,
    pub finished: Option<String>,
}

/// Every point of the sweep in `dir`, in plan order.
pub fn results(dir: &Path, plan: &SweepPlan) -> Result<Vec<PointResult>, String> {
    plan.points
        .iter()
        .map(|p| {
            // As `sweep run` does: a point folder (or its metrics) that is a link leading out
            // of the sweep folder is refused, never read — a received sweep folder is untrusted.
            let run_dir = crate::sandbox::output_path(dir, &p.name).map_err(|e| format!("point {}: {e}", p.name))?;
            let metrics_path = crate::sandbox::output_path(dir, &format!("{}/{METRICS_FILE}", p.name))
                .map_err(|e| format!("point {}: {e}", p.name))?;
            let outcome = read_outcome(dir, &p.name)?;
            let state = match &outcome {
                Some(o) => match o.status {
                    PointStatus::Ok => PointState::Ok,
                    PointStatus::Failed => PointState::Failed(o.error.clone().unwrap_or_default()),
                    PointStatus::Interrupted if is_locked(&run_dir) => PointState::Running,
                    PointStatus::Interrupted => PointState::Interrupted,
                },
                None if is_locked(&run_dir) => PointState::Running,
                None => PointState::Pending,
            };
            let (metrics, metrics_error) = if state == PointState::Ok {
                match std::fs::read_to_string(&metrics_path) {
                    Ok(text) => match parse_metrics(&text) {
                        Ok(m) => (m, None),
                        Err(e) => (vec![], Some(format!("{}/{METRICS_FILE}: {e}", p.name))),
                    },
                    Err(_) => (vec![], Some("the script reported no metrics".to_string())),
                }
            } else {
                (vec![], None)
            };
            Ok(PointResult {
                name: p.name.clone(),
                parameters: p.parameters.clone(),
                state,
                metrics,
                metrics_error,
                wall_s: outcome.as_ref().map(|o| o.wall_s),
                host: outcome.as_ref().map(|o| o.host.clone()),
                started: outcome.as_ref().map(|o| o.started.clone()),
                finished: outcome.as_ref().map(|o| o.finished.clone()),
            })
        })
        .collect()
}

/// Whether a run holds the lock on its folder now.
pub fn is_locked(run_dir: &Path) -> bool {
    use std::os::unix::fs::OpenOptionsExt;
    // Neither through a link nor blocking on a planted FIFO: only a lock file can be held.
    let Ok(file) = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
        .open(run_dir.join(crate::out_lock::LOCK_FILE))
    else {
        return false;
    };
    match file.try_lock_shared() {
        Ok(()) => {
            let _ = file.unlock();
            false
        }
        Err(_) => true,
    }
}

/// Names in first-seen order over `lists`.
fn union<'a>(lists: impl Iterator<Item = &'a [(String, String)]>) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for list in lists {
        for (n, _) in list {
            if !names.contains(n) {
                names.push(n.clone());
            }
        }
    }
    names
}

/// The merged table: one row per point — its parameters, status, every metric (`{:?}`, the
/// shortest text that reads back to the same f64) and a note. Nothing machine-dependent
/// (times, hosts) is in it, so a sweep run on a cluster and one run here compare byte for byte.
pub fn table_csv(plan: &SweepPlan, results: &[PointResult]) -> String {
    let params = union(plan.points.iter().map(|p| p.parameters.as_slice()));
    let mut metrics: Vec<String> = Vec::new();
    for r in results {
        for (n, _) in &r.metrics {
            if !metrics.contains(n) {
                metrics.push(n.clone());
            }
        }
    }
    let mut w = csv::Writer::from_writer(Vec::new());
    let header: Vec<String> = std::iter::once("run".to_string())
        .chain(params.iter().cloned())
        .chain(["status".to_string()])
        .chain(metrics.iter().map(|m| metric_column(m, &params)))
        .chain(["note".to_string()])
        .collect();
    w.write_record(&header).expect("a CSV record written to memory cannot fail");
    for r in results {
        let mut row = vec![r.name.clone()];
        row.extend(
            params.iter().map(|n| r.parameters.iter().find(|(m, _)| m == n).map_or(String::new(), |(_, v)| v.clone())),
        );
        row.push(r.state.label().to_string());
        row.extend(
            metrics
                .iter()
                .map(|n| r.metrics.iter().find(|(m, _)| m == n).map_or(String::new(), |(_, v)| format!("{v:?}"))),
        );
        row.push(match &r.state {
            PointState::Failed(why) => why.clone(),
            _ => r.metrics_error.clone().unwrap_or_default(),
        });
        w.write_record(&row).expect("a CSV record written to memory cannot fail");
    }
    String::from_utf8(w.into_inner().expect("flushing a CSV writer into memory cannot fail"))
        .expect("CSV of UTF-8 text is UTF-8")
}

/// Wall time, host and clock times of each point.
pub fn timings_csv(results: &[PointResult]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(["run", "status", "wall_s", "host", "started", "finished"])
        .expect("a CSV record written to memory cannot fail");
    for r in results {
        let opt = |o: &Option<String>| o.clone().unwrap_or_default();
        w.write_record([
            r.name.clone(),
            r.state.label().to_string(),
            r.wall_s.map_or(String::new(), |t| format!("{t:.3}")),
            opt(&r.host),
            opt(&r.started),
            opt(&r.finished),
        ])
        .expect("a CSV record written to memory cannot fail");
    }
    String::from_utf8(w.into_inner().expect("flushing a CSV writer into memory cannot fail"))
        .expect("CSV of UTF-8 text is UTF-8")
}

/// Counts, then one line per point that failed or is not finished: text for a terminal, so
/// the values and errors it quotes (from the plan and the outcome files) are escaped.
pub fn status_text(dir: &Path, plan: &SweepPlan, results: &[PointResult]) -> String {
    let count = |label: &str| results.iter().filter(|r| r.state.label() == label).count();
    let mut s = format!(
        "sweep {}: {} point(s): {} ok, {} failed, {} running, {} interrupted, {} pending\n",
        dir.display(),
        plan.points.len(),
        count("ok"),
        count("failed"),
        count("running"),
        count("interrupted"),
        count("pending"),
    );
    for r in results {
        let setting = one_line(&setting_text(&r.parameters)).into_owned();
        match &r.state {
            PointState::Failed(why) => {
                let why = one_line(why);
                let _ = writeln!(
                    s,
                    "  {} {setting}: failed: {why} (log: {})",
                    r.name,
                    dir.join(&r.name).join(LOG_FILE).display()
                );
            }
            PointState::Ok => {}
            other => {
                let _ = writeln!(s, "  {} {setting}: {}", r.name, other.label());
            }
        }
    }
    s
}

/// A point's parameters as `a=1 b=2`.
pub fn setting_text(parameters: &[(String, String)]) -> String {
    parameters.iter().map(|(n, v)| format!("{n}={v}")).collect::<Vec<_>>().join(" ")
}

/// Writes the merged table and the timings; returns the files written. A finished sweep is
/// collected by `study::write_collect`, which adds its study's outputs and its page.
pub fn write_tables(dir: &Path, plan: &SweepPlan, results: &[PointResult]) -> Result<Vec<PathBuf>, String> {
    let mut written = Vec::new();
    for (name, text) in [(TABLE_FILE, table_csv(plan, results)), (TIMINGS_FILE, timings_csv(results))] {
        let path = dir.join(name);
        crate::atomic_write::write(&path, text.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}
