//! `matdem-rs study`: what accuracy costs in time. Runs one script at every combination of
//! the varied parameters, times each run, reads the metric the script reports with
//! `report(name, value)`, and writes a table and a chart of error against wall time,
//! relative to the most accurate setting.
//!
//! Each setting runs as a child `matdem-rs run` process in a folder of its own, so one
//! setting that fails (an unstable time step, say) is recorded and the others go on, and the
//! wall time is that of a real run.

use crate::api::metrics::{parse_metrics, METRICS_FILE};
use crate::api::write_atomic;
use crate::plot::LineChart;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

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
    /// Ctrl-C or SIGTERM: the running setting is stopped the same way (it saves its resume
    /// point) and the study ends.
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
    vary.iter().fold(vec![Vec::new()], |acc, v| {
        acc.iter()
            .flat_map(|s| {
                v.values.iter().map(move |x| {
                    let mut s = s.clone();
                    s.push((v.name.clone(), x.clone()));
                    s
                })
            })
            .collect()
    })
}

/// Runs the study; `progress` hears one line per finished run.
pub fn run_study(cfg: &StudyConfig, mut progress: impl FnMut(&str)) -> Result<Study, String> {
    check_config(cfg)?;
    std::fs::create_dir_all(&cfg.out_dir)
        .map_err(|e| format!("cannot create output folder {}: {e}", cfg.out_dir.display()))?;
    let all = settings(&cfg.vary);
    progress(&format!("study: {} setting(s), one run each, in {}/runNN", all.len(), cfg.out_dir.display()));
    let mut runs = Vec::with_capacity(all.len());
    let count = all.len();
    for (k, setting) in all.into_iter().enumerate() {
        let dir = cfg.out_dir.join(format!("run{:02}", k + 1));
        let run = run_one(cfg, setting, &dir)?;
        if cfg.control.is_cancelled() {
            return Err(format!(
                "interrupted during run {} of {count} ({}): runs 1 to {k} finished and are kept in their folders; \
                 the interrupted one can be resumed with `matdem-rs run {} --resume {}`",
                k + 1,
                dir.display(),
                cfg.script.display(),
                dir.display()
            ));
        }
        let shown = match &run.outcome {
            Ok(m) => format!("{} = {m:.6e}", cfg.metric),
            Err(why) => format!("no result: {why}"),
        };
        progress(&format!("run {}: {}  {:.1} s, {shown}", k + 1, describe(&run.setting), run.wall_s));
        runs.push(run);
    }
    let reference = pick_reference(cfg, &runs)?;
    Ok(Study { runs, reference })
}

fn check_config(cfg: &StudyConfig) -> Result<(), String> {
    if cfg.vary.is_empty() {
        return Err("give at least one --vary NAME=v1,v2,...".into());
    }
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

fn run_one(cfg: &StudyConfig, setting: Vec<(String, String)>, dir: &Path) -> Result<StudyRun, String> {
    let mut cmd = Command::new(&cfg.exe);
    cmd.arg("run").arg(&cfg.script).arg("--out").arg(dir);
    let mut backend = cfg.backend.clone();
    for (name, value) in &setting {
        // The backend is a command-line choice, not a script parameter.
        if name == "backend" {
            backend = value.clone();
        } else {
            cmd.arg("--set").arg(format!("{name}={value}"));
        }
    }
    for f in &cfg.fixed {
        cmd.arg("--set").arg(f);
    }
    cmd.arg("--backend").arg(&backend);
    // A stale metrics file from an earlier study must not pass for this run's.
    let _ = std::fs::remove_file(dir.join(METRICS_FILE));
    let start = Instant::now();
    let (status, stdout, stderr) = run_until_cancelled(cmd, &cfg.control, dir)?;
    let wall_s = start.elapsed().as_secs_f64();
    let mut log = stdout;
    log.extend_from_slice(&stderr);
    write_atomic(&dir.join("log.txt"), &log).map_err(|e| format!("cannot write {}/log.txt: {e}", dir.display()))?;
    let outcome = if status.success() {
        read_metric(dir, &cfg.metric)
    } else {
        Err(first_error_line(&String::from_utf8_lossy(&stderr), status.code()))
    };
    Ok(StudyRun { setting, wall_s, outcome })
}

/// Runs `cmd` to its end, its output caught in files beside `dir`; when `control` is
/// cancelled, sends the child SIGTERM (so it saves its resume point) and waits for it.
fn run_until_cancelled(
    mut cmd: Command,
    control: &matdem_engine::backend::RunControl,
    dir: &Path,
) -> Result<(std::process::ExitStatus, Vec<u8>, Vec<u8>), String> {
    let parent = dir.parent().unwrap_or(Path::new("."));
    let name = dir.file_name().unwrap_or_default().to_string_lossy();
    let (out_path, err_path) = (parent.join(format!(".{name}.stdout")), parent.join(format!(".{name}.stderr")));
    let file = |p: &Path| std::fs::File::create(p).map_err(|e| format!("cannot create {}: {e}", p.display()));
    cmd.stdout(file(&out_path)?).stderr(file(&err_path)?).stdin(std::process::Stdio::null());
    let mut child = cmd.spawn().map_err(|e| format!("cannot start {:?}: {e}", cmd.get_program()))?;
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

fn read_metric(dir: &Path, metric: &str) -> Result<f64, String> {
    let path = dir.join(METRICS_FILE);
    let text = std::fs::read_to_string(&path)
        .map_err(|_| format!("the script reported no metrics; add `report(\"{metric}\", value);` to it"))?;
    let metrics = parse_metrics(&text)?;
    let names = || metrics.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", ");
    metrics
        .iter()
        .find(|(n, _)| n == metric)
        .map(|(_, v)| *v)
        .ok_or_else(|| format!("the script did not report `{metric}`; it reported: {}", names()))
}

fn first_error_line(stderr: &str, code: Option<i32>) -> String {
    let line = stderr.lines().find(|l| l.starts_with("error")).unwrap_or("the run failed").trim();
    match code {
        Some(c) => format!("{line} (exit {c})"),
        None => format!("{line} (killed)"),
    }
}

fn pick_reference(cfg: &StudyConfig, runs: &[StudyRun]) -> Result<usize, String> {
    let done = |r: &StudyRun| r.outcome.as_ref().is_ok_and(|m| m.is_finite());
    match &cfg.reference {
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

/// `name=value` pairs as one label.
pub fn describe(setting: &[(String, String)]) -> String {
    setting.iter().map(|(n, v)| format!("{n}={v}")).collect::<Vec<_>>().join(" ")
}

/// The table: one row per run. Cells are quoted per RFC 4180 where they need it; the note
/// (why a run gave no result) is always quoted, as it always was.
pub fn to_csv(study: &Study, cfg: &StudyConfig) -> String {
    let mut header = vec!["run".to_string()];
    header.extend(cfg.vary.iter().map(|v| v.name.clone()));
    header.extend(["wall_s", &cfg.metric, "rel_error", "reference", "note"].map(String::from));
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
pub fn chart(study: &Study, cfg: &StudyConfig) -> LineChart {
    let first = &cfg.vary[0].name;
    let title = format!("What accuracy costs: {} against wall time", cfg.metric);
    let y = format!("|{} − reference| / reference [%]", cfg.metric);
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
pub fn write_outputs(study: &Study, cfg: &StudyConfig) -> Result<Vec<PathBuf>, String> {
    let csv = cfg.out_dir.join("study.csv");
    write_atomic(&csv, to_csv(study, cfg).as_bytes()).map_err(|e| format!("cannot write {}: {e}", csv.display()))?;
    let mut written = vec![csv];
    let results = study.runs.iter().filter(|r| r.outcome.is_ok()).count();
    if results > 1 {
        let files = chart(study, cfg).save(&cfg.out_dir.join("study")).map_err(|e| e.to_string())?;
        written.extend(files);
    }
    Ok(written)
}

/// A short table for the terminal.
pub fn summary(study: &Study, cfg: &StudyConfig) -> String {
    let mut s = format!("{:<40} {:>9} {:>14} {:>10}\n", "setting", "wall [s]", cfg.metric, "error");
    for (i, r) in study.runs.iter().enumerate() {
        let m = r.outcome.as_ref().map_or("-".to_string(), |m| format!("{m:.6e}"));
        let e = match study.error(i) {
            _ if i == study.reference => "reference".to_string(),
            Some(e) => format!("{:.3} %", e * 100.0),
            None => "failed".to_string(),
        };
        s.push_str(&format!("{:<40} {:>9.1} {:>14} {:>10}\n", describe(&r.setting), r.wall_s, m, e));
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
        let cfg = StudyConfig {
            exe: PathBuf::new(),
            script: PathBuf::new(),
            out_dir: PathBuf::new(),
            vary: vec!["x=1".parse().unwrap()],
            fixed: vec![],
            metric: "m".into(),
            reference: None,
            backend: "cpu".into(),
            control: Default::default(),
        };
        let text = to_csv(&study, &cfg);
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
