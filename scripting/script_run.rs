//! Running a script file: reads it, prepares the output folder and the engine, evaluates,
//! and turns every failure into a rendered report; writes the run record; resumes an
//! interrupted run (see [`crate::resume`]).

use crate::api::Host;
use crate::eoutln;
use crate::out_lock::OutLock;
use crate::package::Package;
use crate::report::{render, Sources};
use crate::report_page::{write_run_page, RunSummary};
use crate::resume::{self, Pending, Session};
use crate::run_backend::{kind, RunBackend};
use crate::run_record::{now_utc, sha256_hex, RunRecord};
use crate::sandbox::{Limits, ReadRoot};
use crate::stop::Stop;
use matdem_engine::backend::RunControl;
use rhai::{Dynamic, EvalAltResult, Scope};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// What the command line asked for, resolved.
pub struct RunConfig {
    pub script: PathBuf,
    pub out_dir: PathBuf,
    /// `--set name=value`, typed (a package's defaults and checked values included).
    pub params: Vec<(String, Dynamic)>,
    pub progress: bool,
    pub plan_only: bool,
    /// Where the script's models step (`auto` decides at the first run).
    pub backend: RunBackend,
    /// Set by Ctrl-C or SIGTERM; the engine checks it between chunks of steps.
    pub control: RunControl,
    /// `--resume DIR`: continue the interrupted run whose output folder (or resume folder) is DIR.
    pub resume: Option<PathBuf>,
    /// Set when `script` is a packaged simulator (a folder or an archive); `params` then
    /// already holds its defaults and checked `--set` values.
    pub package: Option<Package>,
    /// The sandbox's limits on operations, call depth and data sizes.
    pub limits: Limits,
}

/// Why a run failed, already worded for a person.
#[derive(Debug)]
pub enum RunError {
    /// The run could not start (unreadable script, output folder not writable): exit 2.
    Setup(String),
    /// The script failed (parse error, runtime error, engine error): exit 1.
    Script(String),
    /// Ctrl-C or SIGTERM: the resume folder is written; exit 130.
    Interrupted(String),
    /// Ctrl-C or SIGTERM where nothing can be resumed (a script loop, a box build): the
    /// outputs so far are kept; exit 130.
    Stopped(String),
}

impl RunError {
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Setup(_) => 2,
            RunError::Script(_) => 1,
            RunError::Interrupted(_) | RunError::Stopped(_) => 130,
        }
    }
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunError::Setup(s) | RunError::Script(s) | RunError::Interrupted(s) | RunError::Stopped(s) => {
                f.write_str(s)
            }
        }
    }
}

/// `out/NAME` for a run given no `--out`, NAME being a package's name or a script's stem;
/// a name that is not one plain folder name (a script called `...rhai` has the stem `..`)
/// falls back to `out/run`, so the default never leads out of `out/`.
pub fn default_out_dir(stem: &std::ffi::OsStr) -> PathBuf {
    let mut parts = Path::new(stem).components();
    match (parts.next(), parts.next()) {
        (Some(std::path::Component::Normal(name)), None) => Path::new("out").join(name),
        _ => PathBuf::from("out/run"),
    }
}

/// Types a `--set` value: integer, float, true/false, else a string.
pub fn parse_value(s: &str) -> Dynamic {
    if let Ok(i) = s.parse::<i64>() {
        return Dynamic::from_int(i);
    }
    if let Ok(x) = s.parse::<f64>() {
        return Dynamic::from_float(x);
    }
    match s {
        "true" => Dynamic::TRUE,
        "false" => Dynamic::FALSE,
        _ => Dynamic::from(s.to_string()),
    }
}

/// Runs the script; returns the files it wrote. Every run folder gets a run record
/// (`run.ron`), written when the run starts and again when it ends.
pub fn run_script(cfg: &RunConfig) -> Result<Vec<PathBuf>, RunError> {
    let (text, path, read_root) = match &cfg.package {
        Some(p) => {
            (p.entry_text().map_err(|e| RunError::Setup(format!("error: {e}")))?, p.entry_label(), p.root.clone())
        }
        None => {
            let text = std::fs::read_to_string(&cfg.script)
                .map_err(|e| RunError::Setup(format!("error: cannot read script {}: {e}", cfg.script.display())))?;
            let dir = cfg.script.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
            let root = ReadRoot::folder(dir).map_err(|e| {
                RunError::Setup(format!("error: cannot open the script's folder {}: {e}", dir.display()))
            })?;
            (text, cfg.script.display().to_string(), root)
        }
    };
    let sha = sha256_hex(text.as_bytes());
    // The journal and the run record keep parameters as text; a resume types them again.
    let params = cfg.params.iter().map(|(k, v)| (k.clone(), v.to_string())).collect();
    let mut backend = cfg.backend.clone();
    let mut session = Session { script_sha256: sha.clone(), params, ..Session::default() };
    if let Some(dir) = &cfg.resume {
        let (journal, models) = resume::load(dir).map_err(RunError::Setup)?;
        if journal.script_sha256 != sha {
            return Err(RunError::Setup(format!(
                "error: {} has changed since the run was interrupted (its SHA-256 differs): resume with the script \
                 as it was, or start a fresh run",
                cfg.script.display()
            )));
        }
        // f64 on the CPU, f32 on a GPU: a run continued on the other would change precision
        // half-way without a word. (The device may differ: only the backend's kind is kept.)
        // An `auto` run continues where the interrupted one stepped, without measuring.
        backend = backend.resumed(&journal.backend);
        if matches!(cfg.backend, RunBackend::Auto(_)) && !matches!(backend, RunBackend::Auto(_)) {
            eoutln!("auto: {}, where the interrupted run stepped (no speed test)", backend.describe());
        }
        let (was, now) = (kind(&journal.backend), backend.describe());
        if !was.is_empty() && was != "auto" && was != kind(&now) {
            return Err(RunError::Setup(format!(
                "error: the interrupted run stepped on {was}, this one would on {}: resume with --backend {was}",
                kind(&now)
            )));
        }
        session.params = journal.params;
        session.entries = journal.entries;
        session.pending = Some(Pending { interrupted: journal.interrupted, models });
    }
    session.backend = backend.describe();
    // Held until the run ends: a second run into this folder is refused, not interleaved.
    let _lock = if cfg.plan_only {
        None
    } else {
        let earlier = earlier_outputs(&cfg.out_dir);
        let lock = OutLock::acquire(&cfg.out_dir, &format!("run {}", cfg.script.display()))
            .map_err(|e| RunError::Setup(format!("error: {e}")))?;
        if earlier > 0 && cfg.resume.is_none() {
            eoutln!(
                "note: {} already holds {earlier} file(s) or folder(s) from an earlier run; those this run does not \
                 write again keep their old contents (give a fresh --out to keep runs apart)",
                cfg.out_dir.display()
            );
        }
        Some(lock)
    };
    let mut record = RunRecord {
        script: cfg.script.display().to_string(),
        script_sha256: sha,
        parameters: session.params.clone(),
        backend: backend.describe(),
        speed_test: None,
        matdem_rs_version: env!("CARGO_PKG_VERSION").to_string(),
        started: now_utc(),
        finished: None,
        status: "running".into(),
        exit_code: None,
        resumed_from: cfg.resume.as_ref().map(|d| d.display().to_string()),
        resume_journal_sha256: None,
    };
    if !cfg.plan_only {
        record.write(&cfg.out_dir).map_err(|e| {
            RunError::Setup(format!("error: cannot write the run record in {}: {e}", cfg.out_dir.display()))
        })?;
    }
    // Verified against run.ron's seal by `resume::load` above.
    let loaded_journal = cfg.resume.as_ref().and_then(|_| resume::journal_sha256(&cfg.out_dir));
    let started = std::time::Instant::now();
    let (result, plans, ran_on) = evaluate(cfg, backend, &text, &path, read_root, session);
    if !cfg.plan_only {
        // `auto` has decided by now, if a model ran.
        (record.backend, record.speed_test) = ran_on;
        let (status, code) = match &result {
            Ok(_) => ("ok", 0),
            Err(RunError::Interrupted(_)) => ("interrupted", 130),
            Err(RunError::Stopped(_)) => ("stopped", 130),
            Err(RunError::Script(_)) => ("failed", 1),
            Err(RunError::Setup(_)) => ("could not start", 2),
        };
        record.finished = Some(now_utc());
        record.status = status.into();
        // An interrupted run seals its new journal; a resume that failed (a changed path, a
        // refused journal) keeps the seal of the journal it loaded, so it can be tried again.
        let journal_now = resume::journal_sha256(&cfg.out_dir);
        record.resume_journal_sha256 = match &result {
            Err(RunError::Interrupted(_)) => journal_now,
            Err(_) if journal_now.is_some() && journal_now == loaded_journal => journal_now,
            _ => None,
        };
        record.exit_code = Some(code);
        // The outputs are what matter; a record that cannot be rewritten is only reported.
        if let Err(e) = record.write(&cfg.out_dir) {
            eoutln!("warning: cannot update the run record in {}: {e}", cfg.out_dir.display());
        }
        if result.is_ok() {
            // A finished run leaves nothing to resume.
            let _ = std::fs::remove_dir_all(resume::resume_dir(&cfg.out_dir));
        }
        let summary = RunSummary {
            record: &record,
            plans,
            wall_s: started.elapsed().as_secs_f64(),
            error: result.as_ref().err().map(|e| e.to_string()),
        };
        if let Err(e) = write_run_page(&cfg.out_dir, &summary) {
            eoutln!("warning: cannot write the run's page in {}: {e}", cfg.out_dir.display());
        }
    }
    result
}

/// How many entries an output folder holds before a run starts (the lock not counted).
fn earlier_outputs(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |entries| {
        entries.filter_map(|e| e.ok()).filter(|e| e.file_name() != crate::out_lock::LOCK_FILE).count()
    })
}

/// Each model's plan, by model name.
type Plans = Vec<(String, String)>;

/// Where a run's models stepped, in words, and the speed test's line if `auto` measured.
type RanOn = (String, Option<String>);

/// Prepares the host and the engine and evaluates the script on `backend`; returns its
/// result, the plans of the models it ran and where they stepped.
fn evaluate(
    cfg: &RunConfig,
    backend: RunBackend,
    text: &str,
    path: &str,
    read_root: ReadRoot,
    session: Session,
) -> (Result<Vec<PathBuf>, RunError>, Plans, RanOn) {
    let mut host = Host::new(cfg.out_dir.clone());
    host.progress = cfg.progress;
    host.plan_only = cfg.plan_only;
    host.control = cfg.control.clone();
    host.backend = RefCell::new(backend);
    host.read_root = read_root;
    host.limits = cfg.limits;
    host.parameters = cfg.package.as_ref().map(|p| p.manifest.parameters.clone()).unwrap_or_default();
    if cfg.resume.is_some() {
        for (k, v) in &session.params {
            host.params.insert(k.as_str().into(), parse_value(v));
        }
    } else {
        for (k, v) in &cfg.params {
            host.params.insert(k.as_str().into(), v.clone());
        }
    }
    host.self_run = own_binary().map(|exe| crate::api::run_points::SelfRun {
        source: cfg.script.clone(),
        params: session.params.clone(),
        exe,
    });
    host.session = RefCell::new(session);
    host.resumable = !cfg.plan_only;
    let host = Rc::new(host);
    let mut engine = crate::new_engine(host.clone());
    // A signal lands where it lands: in a balance, which saves a resume point (see
    // api::model::stepping::run_steps), or in the script's own code between two balances. There
    // the script goes on for up to STOP_GRACE, so that its next run or balance (usually a few
    // operations away) saves the resume point after its first chunk; a script that reaches
    // none in that time (a long loop of its own) is stopped with no resume point.
    // Past --max-memory (values counted after they were made), it stops at once.
    let control = cfg.control.clone();
    let resumable = host.resumable;
    let signalled_at = std::cell::Cell::new(None::<std::time::Instant>);
    engine.on_progress(move |_| {
        if control.is_cancelled() {
            let since = signalled_at.get().unwrap_or_else(std::time::Instant::now);
            signalled_at.set(Some(since));
            if !resumable || since.elapsed() >= STOP_GRACE {
                return Some(Stop::Stopped.token());
            }
        }
        crate::memory::over_limit()
    });
    let sources = Sources { main_path: path, main_text: text, hint: crate::api::hints::for_error };
    let result = compile_and_run(cfg, &mut engine, &host, &sources);
    let plans = host.plans.take();
    let ran_on = (host.backend.borrow().describe(), host.speed_test.take());
    (result, plans, ran_on)
}

/// How long a script signalled between two balances may go on to reach the next one.
const STOP_GRACE: std::time::Duration = std::time::Duration::from_secs(1);

/// The `matdem-rs` binary running this process, which `run_points` starts again for each
/// point; `None` where a run is evaluated inside another program (a test binary), which
/// must not be started with `run` arguments.
fn own_binary() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    (exe.file_stem()? == "matdem-rs").then_some(exe)
}

fn compile_and_run(
    cfg: &RunConfig,
    engine: &mut rhai::Engine,
    host: &Host,
    sources: &Sources,
) -> Result<Vec<PathBuf>, RunError> {
    let text = sources.main_text;
    let ast = engine.compile(text).map_err(|e| RunError::Script(render(&EvalAltResult::from(e), sources)))?;
    host.limits.running(engine);
    let mut scope = Scope::new();
    scope.push_constant("params", host.params.clone());
    scope.push_constant("out_dir", host.out_dir.display().to_string());
    let outcome = engine.run_ast_with_scope(&mut scope, &ast);
    // Movies end with the script, however it ends: an interrupted run keeps their frames for
    // its resume (see crate::movie).
    let interrupted = outcome.as_ref().err().and_then(|e| Stop::of(e)) == Some(Stop::Interrupted);
    let movie_errors = host.finish_movies(interrupted);
    if let (Ok(()), Some(e)) = (&outcome, movie_errors.first()) {
        return Err(RunError::Script(format!("error: {}\n", crate::terminal_text::one_line(e))));
    }
    for e in &movie_errors {
        eoutln!("warning: {}", crate::terminal_text::one_line(e));
    }
    match outcome {
        Ok(()) if host.replaying() => Err(RunError::Script(
            "error: cannot resume: the script ended before it reached the call that was interrupted; resume only \
             with the script and parameters that were interrupted, or start a fresh run\n"
                .into(),
        )),
        Ok(()) => Ok(host.written.borrow().clone()),
        Err(e) if cfg.plan_only && Stop::of(&e) == Some(Stop::PlanDone) => Ok(Vec::new()),
        Err(e) if Stop::of(&e) == Some(Stop::Stopped) => Err(RunError::Stopped(
            "stopped by a signal outside a balance, where there is no resume point: the outputs written so far are \
             kept; run the script again to start over\n"
                .into(),
        )),
        Err(e) if Stop::of(&e) == Some(Stop::Interrupted) => Err(RunError::Interrupted(format!(
            "interrupted: the outputs written so far are kept; continue with\n  matdem-rs run {} --resume {}\n",
            cfg.script.display(),
            cfg.out_dir.display()
        ))),
        Err(e) => Err(RunError::Script(render(&e, sources))),
    }
}
