//! `run`, `plan`, `repl` and `doc`: scripts and packages on the host.

use super::{open_backend, stop_on_signals, Failure, Outcome};
use crate::cli::Backend;
use matdem_engine::backend::RunControl;
use matdem_rs::package::Package;
use matdem_rs::run_backend::RunBackend;
use matdem_rs::sandbox::Limits;
use matdem_rs::script_run::{parse_value, run_script, RunConfig, RunError};
use matdem_rs::{eoutln, out};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

type Params = Vec<(String, rhai::Dynamic)>;

pub fn run(
    script: PathBuf,
    out: Option<PathBuf>,
    resume: Option<PathBuf>,
    set: &[String],
    backend: Backend,
    limits: Limits,
) -> Outcome {
    if resume.is_some() && !set.is_empty() {
        return Err(Failure::error(
            "a resumed run keeps the parameters of the interrupted one (see its run.ron); drop --set",
        ));
    }
    let (package, params) = resolve_source(&script, set)?;
    let stem = match &package {
        Some(p) => p.manifest.name.clone().into(),
        None => script.file_stem().unwrap_or_default().to_os_string(),
    };
    let out_dir = match (out, &resume) {
        (Some(o), Some(dir)) => {
            same_folder(&o, &matdem_rs::resume::run_folder(dir)).map_err(Failure::error)?;
            o
        }
        (Some(o), None) => o,
        (None, Some(dir)) => matdem_rs::resume::run_folder(dir),
        (None, None) => matdem_rs::script_run::default_out_dir(&stem),
    };
    let control = RunControl::default();
    stop_on_signals(&control, "the run without saving a resume point");
    let backend = open_backend(backend)?;
    let cfg = RunConfig {
        script,
        out_dir,
        params,
        progress: std::io::stderr().is_terminal(),
        plan_only: false,
        backend,
        control,
        resume,
        package,
        limits,
    };
    finish(&cfg, run_script(&cfg))
}

pub fn plan(script: PathBuf, set: &[String], limits: Limits) -> Outcome {
    let (package, params) = resolve_source(&script, set)?;
    // `plan` runs the script up to its first step, and what it saves on the way goes to a
    // folder of its own that is removed after: plan writes nothing the user keeps, and no
    // folder a run may be using.
    let scratch = Scratch::new().map_err(Failure::error)?;
    let cfg = RunConfig {
        script,
        out_dir: scratch.0.clone(),
        params,
        progress: false,
        plan_only: true,
        backend: RunBackend::Cpu,
        control: RunControl::default(),
        resume: None,
        package,
        limits,
    };
    finish(&cfg, run_script(&cfg))
}

/// A fresh private folder under the system's temporary folder, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Scratch, String> {
        use std::os::unix::fs::DirBuilderExt;
        let base = std::env::temp_dir();
        for k in 0..100u32 {
            let nanos =
                std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
            let dir = base.join(format!("matdem-rs-plan-{}-{nanos}-{k}", std::process::id()));
            // create, not create_all: a folder (or link) already there is never used.
            match std::fs::DirBuilder::new().mode(0o700).create(&dir) {
                Ok(()) => return Ok(Scratch(dir)),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(format!("cannot create a scratch folder in {}: {e}", base.display())),
            }
        }
        Err(format!("cannot create a scratch folder in {}", base.display()))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn finish(cfg: &RunConfig, result: Result<Vec<PathBuf>, RunError>) -> Outcome {
    match result {
        Ok(written) => {
            if !cfg.plan_only && !written.is_empty() {
                eoutln!("wrote {} file(s) under {}", written.len(), cfg.out_dir.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => Err(Failure::said(e.exit_code(), e.to_string())),
    }
}

pub fn repl(script: Option<PathBuf>, out: Option<PathBuf>, limits: Limits) -> Outcome {
    let out_dir = out.unwrap_or_else(|| PathBuf::from("out/repl"));
    let cfg = matdem_rs::repl::ReplConfig { script, out_dir, limits };
    matdem_rs::repl::run_repl(cfg).map(ExitCode::from).map_err(Failure::error)
}

pub fn doc() -> Outcome {
    let host = std::rc::Rc::new(matdem_rs::api::Host::new(PathBuf::from("out/doc")));
    out!("{}", matdem_rs::api::reference::markdown(&matdem_rs::new_engine(host)));
    Ok(ExitCode::SUCCESS)
}

/// `--set-file FILE`: each (name, value) pair as a `NAME=VALUE` of `--set`.
pub fn read_set_file(file: &Path) -> Result<Vec<String>, Failure> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| Failure::error(format!("--set-file: cannot read {}: {e}", file.display())))?;
    let pairs: Vec<(String, String)> = ron::from_str(&text).map_err(|e| {
        Failure::error(format!("--set-file {}: {e}; write a list of pairs: [(\"n\", \"10\"), …]", file.display()))
    })?;
    Ok(pairs.into_iter().map(|(n, v)| format!("{n}={v}")).collect())
}

/// The package `script` names, if it is one, and the script's parameters: a package's
/// defaults with each `--set` checked against its manifest, or a plain script's values typed
/// by their look.
fn resolve_source(script: &Path, set: &[String]) -> Result<(Option<Package>, Params), Failure> {
    match Package::detect(script).map_err(Failure::error)? {
        Some(p) => {
            let params = p.params(set).map_err(|e| Failure::error(format!("{e}\nnothing was run")))?;
            Ok((Some(p), params))
        }
        None => Ok((None, params(set)?)),
    }
}

fn params(set: &[String]) -> Result<Params, Failure> {
    set.iter()
        .map(|s| match s.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => {
                matdem_rs::package::check_param_name(k.trim())
                    .map_err(|e| Failure::error(format!("--set {s}: {e}")))?;
                let value = parse_value(v.trim());
                // `1e400` reads as inf (and `nan` as NaN): no script means that by a number.
                if value.as_float().is_ok_and(|x| !x.is_finite()) {
                    return Err(Failure::error(format!(
                        "--set {s}: `{}` is not a finite number (a 64-bit float reaches ±1.8e308); give a finite value",
                        v.trim()
                    )));
                }
                Ok((k.trim().to_string(), value))
            }
            _ => Err(Failure::error(format!("--set expects NAME=VALUE, got `{s}`"))),
        })
        .collect()
}

/// A resumed run writes where the interrupted one wrote: `--out` may only name that folder.
fn same_folder(out: &Path, run_folder: &Path) -> Result<(), String> {
    let real = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    if real(out) == real(run_folder) {
        return Ok(());
    }
    Err(format!(
        "--resume continues the run in {}, and writes its remaining outputs there; drop --out {} (or copy the \
         folder there first and resume from the copy)",
        run_folder.display(),
        out.display()
    ))
}
