//! What scripts see: one file per concept, each with a `register` function.
//!
//! MatDEM's nouns in snake_case (see the glossary in the README): `new_box` (obj_Box),
//! the model `d`, `material`, groups, boundaries, `record`/`status`, `plot`, `show`.

pub mod box_builder;
pub mod docs;
pub mod field;
pub mod files;
pub mod materials;
pub mod metrics;
pub mod model;
pub mod plot;
pub mod table;

use crate::sandbox::{output_path, Limits, ReadRoot};
use rhai::{Engine, EvalAltResult};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;

pub type RhaiResult<T> = Result<T, Box<EvalAltResult>>;

/// A script error with a message; Rhai adds the call position.
pub fn err(msg: impl Into<String>) -> Box<EvalAltResult> {
    msg.into().into()
}

/// The only way an engine error becomes a script error.
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
    /// The only place the script may read from (its folder or its package).
    pub read_root: ReadRoot,
    /// Limits on operations, call depth and data sizes.
    pub limits: Limits,
}

/// Marker error that ends a script in `plan` mode once a plan was printed.
pub const PLAN_DONE: &str = "__matdem_plan_done__";

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
        }
    }

    /// Resolves a relative output name inside the output folder; refuses anything that
    /// could land outside it (`..`, absolute paths, symbolic links out).
    pub fn out_path(&self, name: &str) -> RhaiResult<PathBuf> {
        output_path(&self.out_dir, name).map_err(err)
    }

    /// Reads a file of the script's folder or package; refuses anything outside it.
    pub fn read(&self, name: &str) -> RhaiResult<Vec<u8>> {
        self.read_root.read(name).map_err(err)
    }

    pub fn note_written(&self, paths: impl IntoIterator<Item = PathBuf>) {
        self.written.borrow_mut().extend(paths);
    }
}

/// Writes bytes atomically: a temporary file beside the target, then a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = path.with_extension(format!("{}.tmp", path.extension().and_then(|e| e.to_str()).unwrap_or("")));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}

/// Registers the whole script API.
pub fn register(engine: &mut Engine, host: Rc<Host>) {
    field::register(engine);
    table::register(engine, host.clone());
    materials::register(engine);
    metrics::register(engine, host.clone());
    model::register(engine, host.clone());
    box_builder::register(engine);
    files::register(engine, host.clone());
    plot::register(engine, host);
}
