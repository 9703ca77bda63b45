//! `sweep.ron`: what a sweep runs — the source and its digest, the backend, the parameters
//! every point shares, how the points were chosen, and each point's parameters and folder.

use super::digest::source_sha256;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The plan's file name at the top of the sweep folder.
pub const SWEEP_FILE: &str = "sweep.ron";

/// The most points a sweep may plan unless told otherwise (`--max-points`): each point is a
/// run folder and a run, so a grid of three parameters at 300 values each (27 million
/// points) is a mistake to refuse before anything is made, not a plan.
pub const DEFAULT_MAX_POINTS: usize = 10_000;

/// How the points were chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Design {
    /// Every combination of the varied values, the first varying slowest.
    Grid(Vec<(String, Vec<String>)>),
    /// Parameter sets given one by one: a CSV file, an orthogonal design, a calibration's runs.
    /// `from` says where they came from, for people.
    Runs { from: String },
}

/// One point: its run folder's name (under the sweep folder) and its parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlannedPoint {
    pub name: String,
    pub parameters: Vec<(String, String)>,
}

/// The study a sweep feeds, when it was planned by `matdem-rs study` or with `--metric`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudySpec {
    pub metric: String,
    /// The setting errors are measured against; by default the slowest run that finished.
    pub reference: Option<Vec<(String, String)>>,
}

/// `sweep.ron`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepPlan {
    /// The script, package folder or package archive, as an absolute path.
    pub source: PathBuf,
    /// SHA-256 of the source's content; a point refuses to run a source that has changed.
    pub source_sha256: String,
    /// `--backend` of every point that does not vary `backend`.
    pub backend: String,
    /// `--set NAME=VALUE` given to every point.
    pub fixed: Vec<(String, String)>,
    pub design: Design,
    pub study: Option<StudySpec>,
    pub points: Vec<PlannedPoint>,
    /// The matdem-rs that planned it.
    pub matdem_rs_version: String,
}

/// What to plan.
#[derive(Debug, Clone)]
pub struct PlanRequest {
    pub source: PathBuf,
    pub dir: PathBuf,
    pub backend: String,
    pub fixed: Vec<(String, String)>,
    pub design: Design,
    /// One parameter set per point, in order.
    pub runs: Vec<Vec<(String, String)>>,
    pub study: Option<StudySpec>,
    /// A different plan already in `dir` is replaced (its outcomes forgotten) instead of refused.
    pub replace: bool,
    /// The most points it may have (see [`DEFAULT_MAX_POINTS`]).
    pub max_points: usize,
}

/// Why a sweep of `points` (`None`: too many to count) is refused: over `max_points`; `how`
/// says how they came to be, `fewer` how to have fewer.
fn too_many(points: Option<usize>, how: &str, fewer: &str, max_points: usize) -> String {
    let points = points.map_or(format!("more than {max_points}"), |n| n.to_string());
    format!(
        "the sweep would have {points} points ({how}), over --max-points {max_points}: each point is a run folder \
         and a run; {fewer}, or raise the limit with --max-points N if every point is meant"
    )
}

const FEWER_VALUES: &str = "vary fewer values (or give a design's runs with --runs FILE.csv)";

/// The number of points of the grid of `vary`, refused (before any is made) when over
/// `max_points` or beyond counting.
pub fn check_grid_size(vary: &[(String, Vec<String>)], max_points: usize) -> Result<usize, String> {
    let how = vary.iter().map(|(n, v)| format!("{} {n}", v.len())).collect::<Vec<_>>().join(" × ");
    match vary.iter().try_fold(1usize, |n, (_, v)| n.checked_mul(v.len())) {
        Some(n) if n <= max_points => Ok(n),
        Some(n) => Err(too_many(Some(n), &how, FEWER_VALUES, max_points)),
        None => Err(too_many(None, &how, FEWER_VALUES, max_points)),
    }
}

/// Every combination of the varied values, the first changing slowest.
pub fn grid(vary: &[(String, Vec<String>)]) -> Vec<Vec<(String, String)>> {
    vary.iter().fold(vec![Vec::new()], |acc, (name, values)| {
        acc.iter()
            .flat_map(|s| {
                values.iter().map(move |x| {
                    let mut s = s.clone();
                    s.push((name.clone(), x.clone()));
                    s
                })
            })
            .collect()
    })
}

/// Plans the grid of `vary` into `dir`; see [`plan`].
pub fn plan_grid(req: PlanRequest, vary: Vec<(String, Vec<String>)>) -> Result<SweepPlan, String> {
    plan(with_grid(req, vary)?)
}

/// `req` with the grid of `vary` as its points, refused before it is made when it would hold
/// more than `req.max_points`.
pub fn with_grid(mut req: PlanRequest, vary: Vec<(String, Vec<String>)>) -> Result<PlanRequest, String> {
    check_grid_size(&vary, req.max_points)?;
    req.runs = grid(&vary);
    req.design = Design::Grid(vary);
    Ok(req)
}

/// Plans parameter sets given one by one (a calibration design's runs) into `dir`: the
/// plain entry for any caller with a list of runs. `from` says where they came from.
pub fn plan_runs(
    source: &Path,
    dir: &Path,
    runs: Vec<Vec<(String, String)>>,
    from: &str,
    backend: &str,
    fixed: Vec<(String, String)>,
) -> Result<SweepPlan, String> {
    plan(PlanRequest {
        source: source.to_path_buf(),
        dir: dir.to_path_buf(),
        backend: backend.to_string(),
        fixed,
        design: Design::Runs { from: from.to_string() },
        runs,
        study: None,
        replace: false,
        max_points: DEFAULT_MAX_POINTS,
    })
}

/// Writes `sweep.ron` and one run folder per point into `req.dir`. The same plan already
/// there is kept as it is, with its finished points (planning again is how a sweep resumes
/// after a change of machine); a different one is refused unless `req.replace`.
/// Holds the sweep folder's lock while it writes: a run, study or sweep using the folder
/// refuses the plan instead of having it swapped under it.
pub fn plan(req: PlanRequest) -> Result<SweepPlan, String> {
    check_request(&req)?;
    let lock = crate::out_lock::OutLock::acquire(&req.dir, &format!("sweep plan {}", req.dir.display()))?;
    plan_held(&lock, req)
}

/// [`plan`] into the folder `held` locks (a study or `run_points`, which go on to run it).
pub fn plan_held(held: &crate::out_lock::OutLock, req: PlanRequest) -> Result<SweepPlan, String> {
    debug_assert_eq!(held.dir(), req.dir.as_path());
    check_request(&req)?;
    let source =
        std::path::absolute(&req.source).map_err(|e| format!("cannot resolve {}: {e}", req.source.display()))?;
    let width = req.runs.len().to_string().len().max(2);
    let points: Vec<PlannedPoint> = req
        .runs
        .into_iter()
        .enumerate()
        .map(|(k, parameters)| PlannedPoint { name: format!("run{:0width$}", k + 1), parameters })
        .collect();
    let plan = SweepPlan {
        source_sha256: source_sha256(&source)?,
        source,
        backend: req.backend,
        fixed: req.fixed,
        design: req.design,
        study: req.study,
        points,
        matdem_rs_version: env!("CARGO_PKG_VERSION").to_string(),
    };
    plan.check()?;
    std::fs::create_dir_all(&req.dir).map_err(|e| format!("cannot create sweep folder {}: {e}", req.dir.display()))?;
    if req.dir.join(SWEEP_FILE).exists() {
        match load(&req.dir) {
            Ok(old) if old == plan => return Ok(old),
            Ok(_) | Err(_) if req.replace => forget_outcomes(&req.dir)?,
            Ok(_) => {
                return Err(format!(
                    "{} holds a different sweep; give another folder (or `--replace` to plan over it and rerun every \
                     point)",
                    req.dir.display()
                ))
            }
            Err(e) => return Err(format!("{e}; give another folder, or `--replace` to plan over it")),
        }
    }
    for p in &plan.points {
        crate::sandbox::output_path(&req.dir, &p.name)?;
        std::fs::create_dir_all(req.dir.join(&p.name))
            .map_err(|e| format!("cannot create {}: {e}", req.dir.join(&p.name).display()))?;
    }
    save(&req.dir, &plan)?;
    Ok(plan)
}

/// What can be refused before the folder is touched (or locked).
fn check_request(req: &PlanRequest) -> Result<(), String> {
    if req.runs.is_empty() {
        return Err("a sweep needs at least one point; give --vary NAME=v1,v2,... or --runs FILE.csv".into());
    }
    if req.runs.len() > req.max_points {
        return Err(too_many(Some(req.runs.len()), "one per run given", "give fewer runs", req.max_points));
    }
    if !req.source.exists() {
        return Err(format!("cannot read {}: no such file or folder", req.source.display()));
    }
    Ok(())
}

fn forget_outcomes(dir: &Path) -> Result<(), String> {
    let outcomes = dir.join(super::point::OUTCOMES_DIR);
    match std::fs::remove_dir_all(&outcomes) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!("cannot clear {}: {e}", outcomes.display())),
    }
}

fn save(dir: &Path, plan: &SweepPlan) -> Result<(), String> {
    let text = ron::ser::to_string_pretty(plan, ron::ser::PrettyConfig::default())
        .map_err(|e| format!("cannot write the sweep plan: {e}"))?;
    let path = dir.join(SWEEP_FILE);
    crate::atomic_write::write(&path, text.as_bytes()).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Reads and checks `DIR/sweep.ron`.
pub fn load(dir: &Path) -> Result<SweepPlan, String> {
    let path = dir.join(SWEEP_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => {
            format!("{} is not a sweep folder (no {SWEEP_FILE}); make one with `matdem-rs sweep plan`", dir.display())
        }
        _ => format!("cannot read {}: {e}", path.display()),
    })?;
    let plan: SweepPlan = ron::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    plan.check().map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(plan)
}

impl SweepPlan {
    /// A plan read from disk is checked as one that was typed: each point's folder is a
    /// plain name inside the sweep folder, names are parameter names, nothing is twice.
    fn check(&self) -> Result<(), String> {
        let mut seen = std::collections::HashSet::with_capacity(self.points.len());
        for p in &self.points {
            let plain = p.name.starts_with(|c: char| c.is_ascii_alphanumeric())
                && p.name.len() <= 64
                && p.name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
            if !plain || p.name == super::point::OUTCOMES_DIR {
                return Err(format!("point folder `{}` must be a plain name such as run01", p.name.escape_debug()));
            }
            if !seen.insert(p.name.as_str()) {
                return Err(format!("point folder `{}` is given twice", p.name));
            }
            check_names(&p.parameters).map_err(|e| format!("point {}: {e}", p.name))?;
            for (name, _) in &p.parameters {
                // Varied parameters are columns of sweep.csv beside its own.
                if super::collect::OWN_COLUMNS.contains(&name.as_str()) {
                    return Err(format!(
                        "parameter `{name}` would be ambiguous: the sweep's table (sweep.csv) has a `{name}` column \
                         of its own (as it has {}); give the parameter another name in the script or package",
                        super::collect::OWN_COLUMNS.map(|c| format!("`{c}`")).join(", ")
                    ));
                }
                if self.fixed.iter().any(|(f, _)| f == name) {
                    return Err(format!("{name} is both varied and set for every point (--set); drop one"));
                }
            }
        }
        check_names(&self.fixed).map_err(|e| format!("--set: {e}"))
    }

    /// The point called `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }
}

fn check_names(params: &[(String, String)]) -> Result<(), String> {
    for (k, (name, value)) in params.iter().enumerate() {
        if name != "backend" {
            crate::package::check_param_name(name)?;
        } else if !matches!(value.as_str(), "auto" | "cpu" | "gpu") {
            return Err(format!(
                "backend `{}` is not one: give auto, cpu or gpu (e.g. --vary backend=cpu,gpu)",
                value.escape_debug()
            ));
        }
        let plain = !name.is_empty()
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && !name.starts_with(|c: char| c.is_ascii_digit());
        if !plain {
            return Err(format!("parameter name `{}` must be letters, digits and `_`", name.escape_debug()));
        }
        if value.contains(['\n', '\r', '\0']) {
            return Err(format!("the value of {name} holds a line break or NUL"));
        }
        if params[..k].iter().any(|(n, _)| n == name) {
            return Err(format!("parameter {name} is given twice"));
        }
    }
    Ok(())
}

/// Parameter sets from a CSV file: a header of parameter names, one row per run; refused
/// as soon as there are more than `max_points`.
pub fn read_runs_csv(path: &Path, max_points: usize) -> Result<Vec<Vec<(String, String)>>, String> {
    let at = |e: String| format!("{}: {e}", path.display());
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| at(format!("cannot read it: {e}")))?;
    let header: Vec<String> = reader.headers().map_err(|e| at(e.to_string()))?.iter().map(str::to_string).collect();
    let mut runs = Vec::new();
    for (k, row) in reader.records().enumerate() {
        let row = row.map_err(|e| at(e.to_string()))?;
        if row.len() != header.len() || row.iter().any(str::is_empty) {
            return Err(at(format!("row {} needs a value for each of {}", k + 2, header.join(", "))));
        }
        if runs.len() == max_points {
            return Err(at(too_many(None, "one per row", "give fewer rows", max_points)));
        }
        runs.push(header.iter().cloned().zip(row.iter().map(str::to_string)).collect());
    }
    if runs.is_empty() {
        return Err(at("no runs: give a header of parameter names and one row per run".into()));
    }
    Ok(runs)
}

/// Absolute `path`, for the Slurm script and messages that outlive the current folder.
pub fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_is_the_cartesian_product_first_vary_slowest() {
        let v = vec![("a".to_string(), vec!["1".into(), "2".into()]), ("b".into(), vec!["x".into(), "y".into()])];
        let g = grid(&v);
        let label = |s: &Vec<(String, String)>| s.iter().map(|(n, v)| format!("{n}={v}")).collect::<Vec<_>>();
        assert_eq!(g.len(), 4);
        assert_eq!(label(&g[1]), ["a=1", "b=y"]);
        assert_eq!(label(&g[2]), ["a=2", "b=x"]);
    }

    #[test]
    fn a_plan_naming_a_folder_outside_the_sweep_is_refused() {
        let mut p = SweepPlan {
            source: PathBuf::from("/x.rhai"),
            source_sha256: String::new(),
            backend: "cpu".into(),
            fixed: vec![],
            design: Design::Runs { from: "test".into() },
            study: None,
            points: vec![PlannedPoint { name: "../elsewhere".into(), parameters: vec![] }],
            matdem_rs_version: String::new(),
        };
        assert!(p.check().unwrap_err().contains("plain name"));
        p.points[0].name = "outcomes".into();
        assert!(p.check().unwrap_err().contains("plain name"));
        p.points[0].name = "run01".into();
        p.points[0].parameters = vec![("fn".into(), "1".into())];
        assert!(p.check().unwrap_err().contains("reserves"));
        p.points[0].parameters = vec![("x".into(), "1\n#SBATCH".into())];
        assert!(p.check().unwrap_err().contains("line break"));
    }
}
