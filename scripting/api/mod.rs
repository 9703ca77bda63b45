//! What scripts see: one file per concept, each with a `register` function.
//!
//! MatDEM's nouns in snake_case (see the glossary in the README): `new_box` (obj_Box),
//! `new_zoned` (paper 001's zones), the model `d`, `material`, groups, boundaries, `record`/`status`, `plot`, `show`.

pub mod arrays;
pub mod auto_backend;
pub mod box_builder;
pub mod calibration;
pub mod checkpoint;
pub mod docs;
pub mod files;
pub mod geometry;
pub mod hints;
pub mod lists;
pub mod materials;
pub mod metrics;
pub mod model;
pub mod movies;
pub mod options;
pub mod plot;
pub mod reference;
pub mod resume_point;
pub mod run_points;
pub mod snapshots;
pub mod statistics;
pub mod table;
pub mod training;
pub mod zones;

use crate::eoutln;
use crate::resume::{Entry, Session, Value};
use crate::run_backend::RunBackend;
use crate::sandbox::{output_path, Limits, ReadRoot};
use model::{ModelData, ModelHandle};
use rhai::{Dynamic, Engine, EvalAltResult};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::{Rc, Weak};

pub type RhaiResult<T> = Result<T, Box<EvalAltResult>>;

/// A script error with a message; Rhai adds the call position.
pub fn err(msg: impl Into<String>) -> Box<EvalAltResult> {
    msg.into().into()
}

/// The only way an engine error becomes a script error (a run's and a build's through
/// [`Host::raise_engine`], which adds a package's view of the fix).
pub fn raise(e: matdem_engine::Error) -> Box<EvalAltResult> {
    err(e.to_string())
}

/// What a run gives its script: where it may write, its parameters, how to report progress.
pub struct Host {
    /// Every output goes under this folder.
    pub out_dir: PathBuf,
    /// `--set name=value` values, as `params` in the script.
    pub params: rhai::Map,
    /// Draw progress bars (only on a terminal).
    pub progress: bool,
    /// `plan` mode: print each model's step plan at its first run and stop.
    pub plan_only: bool,
    /// Set by Ctrl-C; checked between step chunks.
    pub control: matdem_engine::backend::RunControl,
    /// Files written so far, for the summary.
    pub written: RefCell<Vec<PathBuf>>,
    /// Every model the script created, by creation number (a resume restores them by it).
    pub models: RefCell<Vec<Weak<RefCell<ModelData>>>>,
    /// The journal of what the script saw, and the replay state of a resumed run.
    pub session: RefCell<Session>,
    /// Whether a cancelled run saves a resume point (`matdem-rs run`); elsewhere (the REPL,
    /// in-process engines) nothing is journaled and a cancel is a plain error.
    pub resumable: bool,
    /// Where the run's models step; an undecided `--backend auto` is settled at the first
    /// run or balance ([`auto_backend::settle`]).
    pub backend: RefCell<RunBackend>,
    /// The speed test's line, once `auto` has measured (for `run.ron`).
    pub speed_test: RefCell<Option<String>>,
    /// The only place the script may read from (its folder or its package).
    pub read_root: ReadRoot,
    /// Limits on operations, call depth and data sizes.
    pub limits: Limits,
    /// Warnings given so far, by key: each key is printed once (see [`Host::warn`]).
    pub warnings: RefCell<Vec<(String, String)>>,
    /// Each model's plan as of its first run or balance, by model name, for the run's page.
    pub plans: RefCell<Vec<(String, String)>>,
    /// How to start runs of this run's own source (`run_points`); `matdem-rs run` only.
    pub self_run: Option<run_points::SelfRun>,
    /// A packaged simulator's parameters (empty for a plain script): an engine's suggested
    /// fix is checked against their ranges ([`Host::raise_engine`]).
    pub parameters: Vec<crate::package::Parameter>,
}

impl Host {
    pub fn new(out_dir: PathBuf) -> Self {
        Host {
            out_dir,
            params: rhai::Map::new(),
            progress: false,
            plan_only: false,
            control: Default::default(),
            written: RefCell::new(Vec::new()),
            read_root: ReadRoot::Nothing,
            limits: Limits::default(),
            models: RefCell::new(Vec::new()),
            session: RefCell::new(Session::default()),
            resumable: false,
            backend: RefCell::default(),
            speed_test: RefCell::new(None),
            warnings: RefCell::new(Vec::new()),
            plans: RefCell::new(Vec::new()),
            self_run: None,
            parameters: Vec::new(),
        }
    }

    /// An engine error from a run or a build as a script error ([`raise`]), the numbers of its
    /// fix checked against a package's parameter ranges: where a fix lies outside what the
    /// user can set, the message says so and names what lies within.
    pub fn raise_engine(&self, e: matdem_engine::Error) -> Box<EvalAltResult> {
        if let matdem_engine::Error::Unstable(inst) = &e {
            if let Some(note) = crate::package::fixes::fixes_in_range(&self.parameters, inst) {
                return err(format!("{e}\n{note}"));
            }
        }
        raise(e)
    }

    /// Reads a file the script asks for by name (a checkpoint for `load_model`, a trained
    /// material): the run's output folder first, then the script's own folder or package.
    /// The only place such reads are resolved; returns where it was found and the bytes.
    /// `missing` says what a file that is in neither place is and how to make it.
    pub fn read_input(&self, name: &str, missing: &str) -> RhaiResult<(String, Vec<u8>)> {
        // A name that may not be in the output folder may still be beside the script; if it
        // is neither, the read root says why (a read, not an output path).
        if let Some(in_out) = output_path(&self.out_dir, name).ok().filter(|p| p.is_file()) {
            let bytes = std::fs::read(&in_out).map_err(|e| err(format!("cannot read {}: {e}", in_out.display())))?;
            return Ok((in_out.display().to_string(), bytes));
        }
        match self.read_root.read(name) {
            Ok(bytes) => Ok((name.to_string(), bytes)),
            Err(e) => Err(err(format!(
                "{missing}: looked for `{name}` in the run's output folder {} and beside the script ({e})",
                self.out_dir.display()
            ))),
        }
    }

    /// Gives a new model to the script under the next creation number.
    pub fn adopt(&self, name: &str, model: matdem_engine::Model) -> ModelHandle {
        let mut models = self.models.borrow_mut();
        let handle = ModelHandle::new(name, model, models.len(), self.backend.borrow().target());
        models.push(Rc::downgrade(&handle.0));
        handle
    }

    /// Whether a resumed run is still replaying the part that ran before the interruption.
    pub fn replaying(&self) -> bool {
        self.session.borrow().replaying()
    }

    /// Runs `f`, a call that lets the script see the simulation or writes a file, and
    /// journals what it gave; while replaying, gives back the journaled value instead and
    /// runs nothing (see [`crate::resume`]).
    pub fn observe(&self, call: &str, f: impl FnOnce() -> RhaiResult<Dynamic>) -> RhaiResult<Dynamic> {
        if !self.resumable {
            return f();
        }
        if self.replaying() {
            return self.session.borrow_mut().next(call)?.to_dynamic();
        }
        let result = f();
        let value = match &result {
            Ok(v) => Value::from_dynamic(v).ok_or_else(|| {
                err(format!(
                    "internal error: `{call}` returned a {} that the resume journal cannot hold; please report this bug",
                    v.type_name()
                ))
            })?,
            Err(e) => Value::Error(error_message(e)),
        };
        self.session.borrow_mut().entries.push(Entry { call: call.to_string(), value });
        result
    }

    /// Resolves a relative output name inside the output folder; refuses anything that
    /// could land outside it (`..`, absolute paths, symbolic links out). The only place
    /// writes are resolved.
    pub fn out_path(&self, name: &str) -> RhaiResult<PathBuf> {
        output_path(&self.out_dir, name).map_err(err)
    }

    /// Reads a file of the script's folder or package; refuses anything outside it.
    pub fn read(&self, name: &str) -> RhaiResult<Vec<u8>> {
        self.read_root.read(name).map_err(err)
    }

    /// Prints `warning: {message}` on stderr the first time `key` is warned about, and
    /// keeps it; later warnings with the same key are dropped, so a loop warns once.
    pub fn warn(&self, key: &str, message: String) {
        let mut warnings = self.warnings.borrow_mut();
        if !warnings.iter().any(|(k, _)| k == key) {
            // Warnings quote the script's names and values: escaped for the terminal.
            eoutln!("warning: {}", crate::terminal_text::lines(&message));
            warnings.push((key.to_string(), message));
        }
    }

    pub fn note_written(&self, paths: impl IntoIterator<Item = PathBuf>) {
        self.written.borrow_mut().extend(paths);
    }
}

/// The script error for an engine error of a long native build (a box, zones): a build
/// cancelled by a signal has nothing to resume, so in a run it stops the script like a
/// signal in a script loop (see script_run::evaluate); elsewhere it is a plain error.
pub fn raise_build(host: &Host, e: matdem_engine::Error) -> Box<EvalAltResult> {
    match e {
        matdem_engine::Error::Cancelled { .. } if host.resumable => crate::stop::Stop::Stopped.unwind(),
        e => host.raise_engine(e),
    }
}

/// The script error for a long native call (reading a table, building a design, drawing a
/// chart) given up because a signal set the cancel flag: as [`raise_build`] does for a
/// cancelled build.
pub fn cancelled(host: &Host) -> Box<EvalAltResult> {
    if host.resumable {
        crate::stop::Stop::Stopped.unwind()
    } else {
        err("cancelled by a signal")
    }
}

/// Writes an output file atomically (see [`crate::atomic`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    crate::atomic_write::write(path, bytes)
}

/// The message of a script error without Rhai's position (Rhai adds the position again
/// where the journaled error is given back).
fn error_message(e: &EvalAltResult) -> String {
    match e {
        EvalAltResult::ErrorRuntime(v, _) => v.to_string(),
        other => other.to_string(),
    }
}

/// Registers the whole script API.
pub fn register(engine: &mut Engine, host: Rc<Host>) {
    arrays::register(engine);
    options::register(engine);
    lists::register(engine);
    geometry::register(engine);
    statistics::register(engine);
    table::register(engine, host.clone());
    materials::register(engine);
    metrics::register(engine, host.clone());
    model::register(engine, host.clone());
    checkpoint::register(engine, host.clone());
    box_builder::register(engine, host.clone());
    snapshots::register(engine, host.clone());
    movies::register(engine, host.clone());
    training::register(engine, host.clone());
    files::register(engine, host.clone());
    zones::register(engine, host.clone());
    calibration::register(engine, host.clone());
    run_points::register(engine, host.clone());
    plot::register(engine, host);
}
