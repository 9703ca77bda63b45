//! Running a script file: reads it, prepares the output folder and the engine, evaluates,
//! and turns every failure into a rendered report.

use crate::api::{Host, PLAN_DONE};
use crate::package::Package;
use crate::report::{render, Sources};
use crate::sandbox::{Limits, ReadRoot};
use rhai::{Dynamic, EvalAltResult, Scope};
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// What the command line asked for, resolved.
pub struct RunConfig {
    pub script: PathBuf,
    pub out_dir: PathBuf,
    /// `--set name=value`, already typed.
    pub params: Vec<(String, Dynamic)>,
    pub progress: bool,
    pub plan_only: bool,
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
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunError::Setup(s) | RunError::Script(s) => f.write_str(s),
        }
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

/// Runs the script; returns the files it wrote.
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
    if !cfg.plan_only {
        std::fs::create_dir_all(&cfg.out_dir).map_err(|e| {
            RunError::Setup(format!("error: cannot create output folder {}: {e}", cfg.out_dir.display()))
        })?;
    }
    let mut host = Host::new(cfg.out_dir.clone());
    host.progress = cfg.progress;
    host.plan_only = cfg.plan_only;
    host.read_root = read_root;
    host.limits = cfg.limits;
    for (k, v) in &cfg.params {
        host.params.insert(k.as_str().into(), v.clone());
    }
    let host = Rc::new(host);
    let engine = crate::new_engine(host.clone());
    let sources = Sources { main_path: &path, main_text: &text };
    let ast = engine.compile(&text).map_err(|e| RunError::Script(render(&EvalAltResult::from(e), &sources)))?;
    let mut scope = Scope::new();
    scope.push_constant("params", host.params.clone());
    scope.push_constant("out_dir", host.out_dir.display().to_string());
    match engine.run_ast_with_scope(&mut scope, &ast) {
        Ok(()) => Ok(host.written.borrow().clone()),
        Err(e) if cfg.plan_only && is_plan_done(&e) => Ok(Vec::new()),
        Err(e) => Err(RunError::Script(render(&e, &sources))),
    }
}

fn is_plan_done(e: &EvalAltResult) -> bool {
    match e {
        EvalAltResult::ErrorRuntime(v, _) => v.to_string() == PLAN_DONE,
        EvalAltResult::ErrorInFunctionCall(_, _, inner, _) | EvalAltResult::ErrorInModule(_, inner, _) => {
            is_plan_done(inner)
        }
        _ => false,
    }
}
