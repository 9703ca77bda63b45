//! `run_points(runs, opts)`: a run starts runs of its own script or package at other
//! parameters, several at once, and reads back what each reported — how a calibration runs
//! the rows of its design in parallel across cores (examples/direct_shear_calibration).
//!
//! The points are an ordinary sweep (crate::sweep) planned into a folder of the run's output
//! folder, so each point is a `matdem-rs run` of the same source in its own process and
//! folder (the same sandbox), a finished point is not run again when the run is resumed or
//! repeated into the same folder, and `matdem-rs sweep status|collect` work on that folder.

use super::{err, Host, RhaiResult};
use crate::eoutln;
use crate::sweep::collect::PointState;
use crate::sweep::{self, LocalOptions};
use rhai::{Array, Dynamic, Engine, Map};
use std::path::PathBuf;
use std::rc::Rc;

/// What a run needs to start runs of its own source: set by `matdem-rs run` only (an
/// in-process engine or the REPL has no source to run again).
#[derive(Debug, Clone)]
pub struct SelfRun {
    /// The script, package folder or archive the run was started with.
    pub source: PathBuf,
    /// The run's own parameters: every point gets them, unless its map sets the same name.
    pub params: Vec<(String, String)>,
    /// The `matdem-rs` binary.
    pub exe: PathBuf,
}

/// At most this many points in one call: a design, not a grid search.
const MAX_POINTS: usize = 10_000;

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_fn("run_points", move |runs: Array, opts: Map| -> RhaiResult<Dynamic> {
        host.observe("run_points", || run_points(&host, &runs, &opts).map(Dynamic::from_array))
    });
}

fn run_points(host: &Host, runs: &Array, opts: &Map) -> RhaiResult<Array> {
    let me = host.self_run.as_ref().ok_or_else(|| {
        err("run_points: only a script or package started by `matdem-rs run` can run points of itself")
    })?;
    if host.plan_only {
        return Err(err("run_points: `plan` does not start runs; it shows the plan of this run's own models"));
    }
    // A point of a sweep runs in SWEEP/runNN: starting runs there would nest without end.
    if let Some(parent) = host.out_dir.parent() {
        if parent.join("sweep.ron").is_file() {
            return Err(err(format!(
                "run_points: this run is itself a point of the sweep in {}; a point cannot start runs of its own \
                 (give the points a parameter that makes them run one case)",
                parent.display()
            )));
        }
    }
    for key in opts.keys() {
        if !["jobs", "folder"].contains(&key.as_str()) {
            return Err(err(format!("run_points: unknown option `{key}`; options: jobs, folder")));
        }
    }
    if runs.is_empty() || runs.len() > MAX_POINTS {
        return Err(err(format!("run_points: give 1 to {MAX_POINTS} points (maps of parameters), got {}", runs.len())));
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = match opts.get("jobs") {
        None => cores,
        Some(j) => match j.as_int() {
            Ok(j) if j >= 1 => j as usize,
            _ => return Err(err(format!("run_points: jobs must be an integer ≥ 1, got {j}"))),
        },
    };
    let folder = match opts.get("folder") {
        None => "points".to_string(),
        Some(f) => f.clone().into_string().map_err(|_| err("run_points: folder must be a string"))?,
    };
    let dir = host.out_path(&folder)?;
    let mut sets = Vec::with_capacity(runs.len());
    for (k, run) in runs.iter().enumerate() {
        let map = run.read_lock::<Map>().ok_or_else(|| {
            err(format!("run_points: point {} must be a map of parameters, got {}", k + 1, run.type_name()))
        })?;
        let set: Vec<(String, String)> = map.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect();
        if let Some((n, v)) = set.iter().find(|(_, v)| v.contains(['\n', '\r']) || v.is_empty()) {
            return Err(err(format!("run_points: point {}: parameter `{n}` has no one-line value ({v:?})", k + 1)));
        }
        sets.push(set);
    }
    // The run's own parameters go to every point, except those some point sets itself.
    let fixed: Vec<(String, String)> =
        me.params.iter().filter(|(n, _)| !sets.iter().any(|s| s.iter().any(|(m, _)| m == n))).cloned().collect();
    let lock = crate::out_lock::OutLock::acquire(&dir, &format!("run_points {}", dir.display()))
        .map_err(|e| err(format!("run_points: {e}")))?;
    let plan = sweep::plan::plan_held(
        &lock,
        sweep::PlanRequest {
            source: me.source.clone(),
            dir: dir.clone(),
            // The run's backend once decided; before that, each point's `auto` decides.
            backend: host.backend.borrow().cli_name().to_string(),
            fixed,
            design: sweep::Design::Runs { from: "run_points".into() },
            runs: sets,
            study: None,
            replace: true,
            max_points: MAX_POINTS,
        },
    )
    .map_err(|e| err(format!("run_points: {e}")))?;
    let options = LocalOptions { jobs, retry_failed: true, exe: me.exe.clone(), control: host.control.clone() };
    sweep::run_local_held(&lock, &plan, &options, |line| eoutln!("{line}"))
        .map_err(|e| err(format!("run_points: {e}")))?;
    drop(lock);
    if host.control.is_cancelled() {
        return Err(crate::stop::Stop::Stopped.unwind());
    }
    let results = sweep::results(&dir, &plan).map_err(|e| err(format!("run_points: {e}")))?;
    host.note_written([dir.join("sweep.ron")]);
    Ok(results
        .into_iter()
        .map(|r| {
            let ok = matches!(r.state, PointState::Ok) && r.metrics_error.is_none();
            let error = match &r.state {
                PointState::Failed(why) => why.clone(),
                _ => r.metrics_error.clone().unwrap_or_default(),
            };
            let metrics: Map = r.metrics.iter().map(|(n, v)| (n.as_str().into(), Dynamic::from_float(*v))).collect();
            let mut m = Map::new();
            m.insert("name".into(), r.name.clone().into());
            m.insert("ok".into(), ok.into());
            m.insert("error".into(), error.into());
            m.insert("wall_s".into(), Dynamic::from_float(r.wall_s.unwrap_or(f64::NAN)));
            m.insert("metrics".into(), metrics.into());
            Dynamic::from_map(m)
        })
        .collect())
}
