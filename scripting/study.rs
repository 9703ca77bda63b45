//! `matdem-rs study`: what accuracy costs in time. Runs one script at every combination of
//! the varied parameters, times each run, reads the metric the script reports with
//! `report(name, value)`, and writes a table and a chart of error against wall time,
//! relative to the most accurate setting.
//!
//! A study is a sweep (see [`crate::sweep`]) run on this machine: each setting runs as a
//! child `matdem-rs run` process in a folder of its own, `-j N` at a time, so one setting
//! that fails (an unstable time step, say) is recorded and the others go on, the wall time is
//! that of a real run, and an interrupted study finishes where it stopped.

use crate::metrics::METRICS_FILE;
use crate::plot::LineChart;
use crate::sweep::collect::{PointResult, PointState};
use crate::sweep::plan::{grid, Design, PlanRequest, StudySpec, SweepPlan};
use crate::sweep::LocalOptions;
use crate::terminal_text::one_line;
use std::path::{Path, PathBuf};

/// One `--vary NAME=v1,v2,...`.
#[derive(Debug, Clone, PartialEq)]
pub struct Vary {
    pub name: String,
    pub values: Vec<String>,
}

impl std::str::FromStr for Vary {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (name, values) = s
            .split_once('=')
            .ok_or_else(|| format!("--vary expects NAME=v1,v2,..., got `{s}` (e.g. --vary dt_rate=0.25,0.5,1)"))?;
        let name = name.trim().to_string();
        let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).collect();
        if name.is_empty() || values.iter().any(|v| v.is_empty()) {
            return Err(format!("--vary `{s}`: give a name and non-empty values, e.g. --vary dt_rate=0.25,0.5,1"));
        }
        Ok(Vary { name, values })
    }
}

/// What the command line asked for.
pub struct StudyConfig {
    /// The `matdem-rs` binary that runs each setting.
    pub exe: PathBuf,
    pub script: PathBuf,
    pub out_dir: PathBuf,
    pub vary: Vec<Vary>,
    /// `--set NAME=VALUE` given to every run.
    pub fixed: Vec<String>,
    pub metric: String,
    /// `NAME=VALUE` pairs naming the reference setting; by default the slowest run that
    /// finished (the most expensive setting is taken as the most accurate).
    pub reference: Option<Vec<(String, String)>>,
    /// `--backend` for runs that do not vary `backend`.
    pub backend: String,
    /// Settings run at once, each in its own process.
    pub jobs: usize,
    /// The most settings the grid may have.
    pub max_points: usize,
    /// Ctrl-C or SIGTERM: the running settings are stopped the same way (they save their
    /// resume points) and the study ends; running it again finishes it.
    pub control: matdem_engine::backend::RunControl,
}

/// One setting and what its run gave.
#[derive(Debug, Clone)]
pub struct StudyRun {
    pub setting: Vec<(String, String)>,
    pub wall_s: f64,
    /// The metric, or why the run gave none.
    pub outcome: Result<f64, String>,
}

/// Every run, and the reference they are compared with.
#[derive(Debug)]
pub struct Study {
    pub runs: Vec<StudyRun>,
    pub reference: usize,
}

impl Study {
    /// Error of run `i` relative to the reference (absolute if the reference value is 0).
    pub fn error(&self, i: usize) -> Option<f64> {
        let r = *self.runs[self.reference].outcome.as_ref().ok()?;
        let m = *self.runs[i].outcome.as_ref().ok()?;
        Some(if r == 0.0 { (m - r).abs() } else { ((m - r) / r).abs() })
    }
}

/// Every combination of the varied values, the first `--vary` changing slowest.
pub fn settings(vary: &[Vary]) -> Vec<Vec<(String, String)>> {
    grid(&as_grid(vary))
}

fn as_grid(vary: &[Vary]) -> Vec<(String, Vec<String>)> {
    vary.iter().map(|v| (v.name.clone(), v.values.clone())).collect()
}

/// Runs the study as a sweep in `cfg.out_dir` (planned there, run locally, `cfg.jobs` at a
/// time); `progress` hears one line per finished run. The same study run again into the
/// same folder skips the settings that finished; a changed one starts over. Returns the
/// study and the files written (the sweep's table and timings, the study's table and chart).
pub fn run_study(cfg: &StudyConfig, progress: impl Fn(&str) + Sync) -> Result<(Study, Vec<PathBuf>), String> {
    check_config(cfg)?;
    let fixed = cfg
        .fixed
        .iter()
        .map(|f| match f.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
            _ => Err(format!("--set expects NAME=VALUE, got `{f}`")),
        })
        .collect::<Result<Vec<_>, String>>()?;
    let spec = StudySpec { metric: cfg.metric.clone(), reference: cfg.reference.clone() };
    let request = PlanRequest {
        source: cfg.script.clone(),
        dir: cfg.out_dir.clone(),
        backend: cfg.backend.clone(),
        fixed,
        design: Design::Runs { from: String::new() },
        runs: Vec::new(),
        study: Some(spec.clone()),
        replace: true,
        max_points: cfg.max_points,
    };
    // Locked before anything is written, and held from the plan to the study's own table.
    let lock = crate::out_lock::OutLock::acquire(&cfg.out_dir, &format!("study {}", cfg.script.display()))?;
    let plan = crate::sweep::plan::plan_held(&lock, crate::sweep::plan::with_grid(request, as_grid(&cfg.vary))?)?;
    progress(&format!("study: {} setting(s), one run each, in {}/runNN", plan.points.len(), cfg.out_dir.display()));
    let opts = LocalOptions { jobs: cfg.jobs, retry_failed: true, exe: cfg.exe.clone(), control: cfg.control.clone() };
    crate::sweep::run_local_held(&lock, &plan, &opts, &progress)?;
    let results = crate::sweep::results(&cfg.out_dir, &plan)?;
    for (r, run) in results.iter().zip(study_runs(&spec, &results)) {
        let shown = match &run.outcome {
            Ok(m) => format!("{} = {m:.6e}", cfg.metric),
            Err(why) => format!("no result: {}", one_line(why)),
        };
        // A terminal line: the values and the error are escaped.
        progress(&format!("{}: {}  {:.1} s, {shown}", r.name, one_line(&describe(&run.setting)), run.wall_s));
    }
    let study = from_results(&spec, &results)?;
    let written = write_collect(&cfg.out_dir, &plan, &results)?;
    Ok((study, written))
}

/// Collects a finished sweep into its folder: the sweep's merged table and timings, the
/// study's table and chart when the sweep feeds one (planned by `matdem-rs study` or with
/// `--metric`), then the sweep's page, last so it shows them; returns the files written.
/// Here, above the sweep, because it joins the sweep and its study (`matdem-rs sweep
/// collect` ends here too).
pub fn write_collect(dir: &Path, plan: &SweepPlan, results: &[PointResult]) -> Result<Vec<PathBuf>, String> {
    let mut written = crate::sweep::collect::write_tables(dir, plan, results)?;
    if let Some(spec) = &plan.study {
        let study = from_results(spec, results)?;
        written.extend(write_outputs(&study, spec, dir)?);
    }
    // Last, so the page shows the charts and tables just written.
    let page = crate::sweep::page::write_sweep_page(dir, plan, results)
        .map_err(|e| format!("cannot write {}: {e}", dir.join(crate::report_page::PAGE_FILE).display()))?;
    written.push(page);
    Ok(written)
}

fn check_config(cfg: &StudyConfig) -> Result<(), String> {
    // Before any point runs: a name no script can report would be found only at the end.
    crate::metrics::check_metric_name(&cfg.metric).map_err(|e| format!("--metric: {e}"))?;
    if cfg.vary.is_empty() {
        return Err("give at least one --vary NAME=v1,v2,...".into());
    }
    crate::sweep::plan::check_grid_size(&as_grid(&cfg.vary), cfg.max_points)?;
    for (i, v) in cfg.vary.iter().enumerate() {
        if cfg.vary[..i].iter().any(|w| w.name == v.name) {
            return Err(format!("--vary {} is given twice; list all its values in one --vary", v.name));
        }
        if cfg.fixed.iter().any(|f| f.split_once('=').is_some_and(|(n, _)| n.trim() == v.name)) {
            return Err(format!("{} is both varied and set with --set; drop one", v.name));
        }
    }
    if !cfg.script.exists() {
        return Err(format!("cannot read script {}: no such file", cfg.script.display()));
    }
    if let Some(want) = &cfg.reference {
        if !settings(&cfg.vary).iter().any(|s| want.iter().all(|w| s.contains(w))) {
            return Err(format!(
                "--reference {} matches no setting of the --vary grid; name one of its values for each parameter \
                 given, e.g. --reference {}",
                describe(want),
                describe(&settings(&cfg.vary)[0])
            ));
        }
    }
    Ok(())
}

/// The study of a sweep's points: each run's metric (or why it has none) and the reference.
pub fn from_results(spec: &StudySpec, results: &[PointResult]) -> Result<Study, String> {
    let runs = study_runs(spec, results);
    let reference = pick_reference(spec, &runs)?;
    Ok(Study { runs, reference })
}

/// Each point's metric, or why it has none.
fn study_runs(spec: &StudySpec, results: &[PointResult]) -> Vec<StudyRun> {
    let metric = &spec.metric;
    results
        .iter()
        .map(|r| {
            let outcome = match &r.state {
                PointState::Ok => match r.metrics.iter().find(|(n, _)| n == metric) {
                    Some((_, v)) => Ok(*v),
                    None if r.metrics.is_empty() => Err(match &r.metrics_error {
                        Some(e) if e.contains(METRICS_FILE) => e.clone(),
                        _ => format!("the script reported no metrics; add `report(\"{metric}\", value);` to it"),
                    }),
                    None => {
                        let names = r.metrics.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", ");
                        Err(format!("the script did not report `{metric}`; it reported: {names}"))
                    }
                },
                PointState::Failed(why) => Err(why.clone()),
                other => Err(format!("not run ({})", other.label())),
            };
            StudyRun { setting: r.parameters.clone(), wall_s: r.wall_s.unwrap_or(0.0), outcome }
        })
        .collect()
}

fn pick_reference(spec: &StudySpec, runs: &[StudyRun]) -> Result<usize, String> {
    let done = |r: &StudyRun| r.outcome.as_ref().is_ok_and(|m| m.is_finite());
    match &spec.reference {
        Some(want) => {
            let i = runs
                .iter()
                .position(|r| want.iter().all(|w| r.setting.contains(w)))
                .ok_or_else(|| format!("--reference {} matches no setting", describe(want)))?;
            if !done(&runs[i]) {
                return Err(format!("the reference setting {} gave no result", describe(want)));
            }
            Ok(i)
        }
        None => runs
            .iter()
            .enumerate()
            .filter(|(_, r)| done(r))
            .max_by(|a, b| a.1.wall_s.total_cmp(&b.1.wall_s))
            .map(|(i, _)| i)
            .ok_or_else(|| "no run gave a result; see the log.txt of each run".to_string()),
    }
}

/// The varied parameters' names, as the runs list them.
fn varied(study: &Study) -> Vec<String> {
    study.runs.first().map(|r| r.setting.iter().map(|(n, _)| n.clone()).collect()).unwrap_or_default()
}

/// `name=value` pairs as one label.
pub fn describe(setting: &[(String, String)]) -> String {
    setting.iter().map(|(n, v)| format!("{n}={v}")).collect::<Vec<_>>().join(" ")
}

/// The table: one row per run. Cells are quoted per RFC 4180 where they need it; the note
/// (why a run gave no result) is always quoted, as it always was.
pub fn to_csv(study: &Study, metric: &str) -> String {
    let mut header = vec!["run".to_string()];
    header.extend(varied(study));
    header.extend(["wall_s", metric, "rel_error", "reference", "note"].map(String::from));
    let mut s = csv_line(&header, None);
    for (i, r) in study.runs.iter().enumerate() {
        let (metric, note) = match &r.outcome {
            Ok(m) => (format!("{m:?}"), ""),
            Err(why) => (String::new(), why.as_str()),
        };
        let mut row = vec![(i + 1).to_string()];
        row.extend(r.setting.iter().map(|(_, v)| v.clone()));
        let error = study.error(i).map_or(String::new(), |e| format!("{e:?}"));
        row.extend([format!("{:.3}", r.wall_s), metric, error, (i == study.reference).to_string()]);
        s.push_str(&csv_line(&row, Some(note)));
    }
    s
}

/// One CSV line of `fields`, quoted where needed, then `always_quoted` if given.
fn csv_line(fields: &[String], always_quoted: Option<&str>) -> String {
    let text = |w: csv::Writer<Vec<u8>>| {
        String::from_utf8(w.into_inner().expect("flushing a CSV writer into memory cannot fail"))
            .expect("CSV of UTF-8 text is UTF-8")
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(fields).expect("a CSV record written to memory cannot fail");
    let mut line = text(w);
    if let Some(last) = always_quoted {
        let mut q = csv::WriterBuilder::new().quote_style(csv::QuoteStyle::Always).from_writer(Vec::new());
        q.write_record([last]).expect("a CSV record written to memory cannot fail");
        line.pop();
        line.push(',');
        line.push_str(&text(q));
    }
    line
}

/// Error (%) against wall time: one series per combination of all but the first varied
/// parameter, tracing the first one's values.
pub fn chart(study: &Study, metric: &str) -> LineChart {
    let first = &varied(study)[0];
    let title = format!("What accuracy costs: {metric} against wall time");
    let y = format!("|{metric} − reference| / reference [%]");
    let mut c = LineChart::new(title, "wall time [s]", y);
    let mut groups: Vec<(String, Vec<f64>, Vec<f64>)> = Vec::new();
    for (i, r) in study.runs.iter().enumerate() {
        let Some(e) = study.error(i) else { continue };
        let rest: Vec<(String, String)> = r.setting.iter().filter(|(n, _)| n != first).cloned().collect();
        let label =
            if rest.is_empty() { format!("varying {first}") } else { format!("{} (varying {first})", describe(&rest)) };
        match groups.iter_mut().find(|g| g.0 == label) {
            Some(g) => {
                g.1.push(r.wall_s);
                g.2.push(e * 100.0);
            }
            None => groups.push((label, vec![r.wall_s], vec![e * 100.0])),
        }
    }
    for (label, x, y) in groups {
        c.add_series(label, x, y);
    }
    c
}

/// Writes `study.csv` and the chart; returns the files written.
pub fn write_outputs(study: &Study, spec: &StudySpec, dir: &Path) -> Result<Vec<PathBuf>, String> {
    let csv = dir.join("study.csv");
    crate::atomic_write::write(&csv, to_csv(study, &spec.metric).as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", csv.display()))?;
    let mut written = vec![csv];
    let results = study.runs.iter().filter(|r| r.outcome.is_ok()).count();
    if results > 1 {
        let files = chart(study, &spec.metric).save(&dir.join("study")).map_err(|e| e.to_string())?;
        written.extend(files);
    }
    Ok(written)
}

/// A short table for the terminal (values escaped).
pub fn summary(study: &Study, metric: &str) -> String {
    let mut s = format!("{:<40} {:>9} {:>14} {:>10}\n", "setting", "wall [s]", metric, "error");
    for (i, r) in study.runs.iter().enumerate() {
        let m = r.outcome.as_ref().map_or("-".to_string(), |m| format!("{m:.6e}"));
        let e = match study.error(i) {
            _ if i == study.reference => "reference".to_string(),
            Some(e) => format!("{:.3} %", e * 100.0),
            None => "failed".to_string(),
        };
        s.push_str(&format!("{:<40} {:>9.1} {:>14} {:>10}\n", one_line(&describe(&r.setting)), r.wall_s, m, e));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_the_cartesian_product_first_vary_slowest() {
        let v: Vec<Vary> = ["a=1,2", "b=x,y,z"].iter().map(|s| s.parse().unwrap()).collect();
        let s = settings(&v);
        assert_eq!(s.len(), 6);
        assert_eq!(describe(&s[0]), "a=1 b=x");
        assert_eq!(describe(&s[2]), "a=1 b=z");
        assert_eq!(describe(&s[3]), "a=2 b=x");
    }

    #[test]
    fn vary_without_values_is_refused_with_an_example() {
        for bad in ["dt_rate", "dt_rate=", "=1,2", "dt_rate=1,,2"] {
            let e = bad.parse::<Vary>().unwrap_err();
            assert!(e.contains("--vary"), "{e}");
        }
    }

    #[test]
    fn a_note_with_quotes_commas_and_line_breaks_stays_one_csv_cell() {
        let why = "error: `x` must be \"positive\", got -1\nsee the log";
        let run =
            |m: Result<f64, String>| StudyRun { setting: vec![("x".into(), "a,b".into())], wall_s: 1.0, outcome: m };
        let study = Study { runs: vec![run(Err(why.into())), run(Ok(2.0))], reference: 1 };
        let text = to_csv(&study, "m");
        assert!(text.starts_with("run,x,wall_s,m,rel_error,reference,note\n"), "{text}");
        assert!(text.ends_with("2,\"a,b\",1.000,2.0,0.0,true,\"\"\n"), "{text}");
        let rows: Vec<csv::StringRecord> =
            csv::Reader::from_reader(text.as_bytes()).records().map(Result::unwrap).collect();
        assert_eq!(rows.len(), 2, "{text}");
        assert_eq!((&rows[0][1], &rows[0][6]), ("a,b", why));
    }

    #[test]
    fn error_is_relative_to_the_reference_run() {
        let run = |m: Result<f64, String>| StudyRun { setting: vec![], wall_s: 1.0, outcome: m };
        let s = Study { runs: vec![run(Ok(1.1)), run(Ok(1.0)), run(Err("unstable".into()))], reference: 1 };
        assert!((s.error(0).unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(s.error(1), Some(0.0));
        assert_eq!(s.error(2), None);
    }
}
