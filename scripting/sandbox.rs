//! The sandbox a script runs in: it reads only inside its own folder (or its package's
//! archive, held in memory) and the embedded stdlib, writes only inside the run's output
//! folder, and runs under limits on operations, call depth and data sizes.
//!
//! Rhai's `Engine::new()` exposes no file, process, network or environment functions; every
//! path the script API takes goes through [`ReadRoot::read`] or [`output_path`].

pub mod size_checks;

use rhai::module_resolvers::StaticModuleResolver;
use rhai::{Engine, EvalAltResult, Module, ModuleResolver, Position, Scope, Shared};
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use std::rc::Rc;

/// The most a single read may return: data files, not disk images.
const MAX_READ_BYTES: u64 = 256 << 20;

/// Where a script may read from.
#[derive(Clone, Debug)]
pub enum ReadRoot {
    /// A folder on disk, canonical (symbolic links resolved), so a link out is detectable.
    Folder(PathBuf),
    /// The files of a packed archive, by relative path with `/` separators.
    Archive { label: String, files: Rc<BTreeMap<String, Vec<u8>>> },
    /// Nothing to read (an in-process engine with no script file).
    Nothing,
}

impl ReadRoot {
    /// The canonical form of `dir`, as a read root.
    pub fn folder(dir: &Path) -> std::io::Result<Self> {
        Ok(ReadRoot::Folder(std::fs::canonicalize(dir)?))
    }

    fn describe(&self) -> String {
        match self {
            ReadRoot::Folder(p) => p.display().to_string(),
            ReadRoot::Archive { label, .. } => label.clone(),
            ReadRoot::Nothing => "no folder".to_string(),
        }
    }

    /// The bytes of `name`, a path relative to the root; `..`, absolute paths and symbolic
    /// links that lead out are refused.
    pub fn read(&self, name: &str) -> Result<Vec<u8>, String> {
        let parts = relative_parts(name).map_err(|why| self.outside(name, why))?;
        match self {
            ReadRoot::Folder(root) => {
                let path = parts.iter().fold(root.clone(), |p, c| p.join(c));
                let real = std::fs::canonicalize(&path)
                    .map_err(|e| format!("cannot read `{name}` in {}: {e}", root.display()))?;
                if !real.starts_with(root) {
                    return Err(self.outside(name, "a symbolic link leads out of the script's folder"));
                }
                let meta = std::fs::metadata(&real).map_err(|e| format!("cannot read `{name}`: {e}"))?;
                if !meta.is_file() {
                    return Err(format!("cannot read `{name}`: it is not a file"));
                }
                if meta.len() > MAX_READ_BYTES {
                    return Err(format!(
                        "cannot read `{name}`: {} bytes is over the {MAX_READ_BYTES}-byte limit",
                        meta.len()
                    ));
                }
                std::fs::read(&real).map_err(|e| format!("cannot read `{name}`: {e}"))
            }
            ReadRoot::Archive { label, files } => files
                .get(&parts.join("/"))
                .cloned()
                .ok_or_else(|| format!("cannot read `{name}`: no such file in {label}")),
            ReadRoot::Nothing => Err(format!("cannot read `{name}`: this session has no script folder to read from")),
        }
    }

    fn outside(&self, name: &str, why: &str) -> String {
        format!(
            "path `{name}` is outside the allowed folders ({why}); a script reads only inside its own folder ({}) \
             — give a path relative to it",
            self.describe()
        )
    }
}

/// The components of a relative path that stays inside its root, or why it does not.
fn relative_parts(name: &str) -> Result<Vec<String>, &'static str> {
    let p = Path::new(name);
    if name.is_empty() {
        return Err("an empty path");
    }
    if name.contains('\0') {
        return Err("a NUL byte in the path");
    }
    let mut parts = Vec::new();
    for c in p.components() {
        match c {
            Component::Normal(s) => parts.push(s.to_string_lossy().into_owned()),
            Component::CurDir => {}
            Component::ParentDir => return Err("`..` climbs out"),
            Component::RootDir | Component::Prefix(_) => return Err("an absolute path"),
        }
    }
    if parts.is_empty() {
        return Err("the path names the folder itself");
    }
    Ok(parts)
}

/// The report page of every run and sweep folder (`report_page` and the sweep write it).
/// This name and [`LOG_FILE`] are defined here, where they are reserved, because the sandbox
/// sits below the modules that write them (tests/module_layers.rs).
pub const PAGE_FILE: &str = "index.html";

/// A sweep point's output (stdout, then stderr) in its run folder (`sweep::point` writes it).
pub const LOG_FILE: &str = "log.txt";

/// What the host writes at the top of an output folder, with what each is: no script may
/// write over it or read it back, and a script's file of that name would be replaced without
/// a word. A sweep point's folder is a run's output folder, so its log is reserved in every
/// run (the same script runs alone and in a sweep).
pub const HOST_OWNED: &[(&str, &str)] = &[
    (crate::run_record::RUN_RECORD, "the run record"),
    (crate::resume::RESUME_DIR, "the resume point"),
    (crate::out_lock::LOCK_FILE, "the folder's lock"),
    (PAGE_FILE, "the run's report page"),
    (crate::metrics::METRICS_FILE, "what `report` writes"),
    (LOG_FILE, "a sweep point's log"),
];

/// Where output `name` of a script goes inside `out_dir`. Refuses `..`, absolute paths, any
/// existing part of the path that is a symbolic link leading out of the output folder, and
/// the names the host writes there itself ([`HOST_OWNED`]).
pub fn output_path(out_dir: &Path, name: &str) -> Result<PathBuf, String> {
    let parts = relative_parts(name).map_err(|why| outside(out_dir, name, why))?;
    if let Some((reserved, what)) = HOST_OWNED.iter().find(|(r, _)| parts[0].eq_ignore_ascii_case(r)) {
        return Err(format!(
            "output path `{name}` is refused: `{reserved}` in the output folder belongs to matdem-rs ({what}), \
             which writes it itself; choose another name, e.g. `my_{}`",
            parts.join("/")
        ));
    }
    host_output_path(out_dir, name)
}

/// Where the host's own output `name` (one of [`HOST_OWNED`]) goes: the checks of
/// [`output_path`] but the reservation.
pub(crate) fn host_output_path(out_dir: &Path, name: &str) -> Result<PathBuf, String> {
    let outside = |why: &str| outside(out_dir, name, why);
    let parts = relative_parts(name).map_err(outside)?;
    let real_out = std::fs::canonicalize(out_dir).unwrap_or_else(|_| out_dir.to_path_buf());
    let mut path = out_dir.to_path_buf();
    for part in &parts {
        path.push(part);
        // Only what exists can be a link; a dangling link fails canonicalize and is refused.
        if std::fs::symlink_metadata(&path).is_ok() {
            let real = std::fs::canonicalize(&path).map_err(|_| outside("a dangling symbolic link"))?;
            if !real.starts_with(&real_out) {
                return Err(outside("a symbolic link leads out of the output folder"));
            }
        }
    }
    Ok(path)
}

fn outside(out_dir: &Path, name: &str, why: &str) -> String {
    format!(
        "output path `{name}` is outside the allowed folders ({why}): give a relative name without `..`; it is \
         written under the run's output folder {}",
        out_dir.display()
    )
}

/// Limits on what a script may consume; the defaults let the oedometer's full run through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Bytes the fields, masks, tables and charts of a run may hold together (see
    /// [`crate::memory`]).
    pub max_memory: u64,
    /// Rhai operations in one run (native calls count as one, whatever they cost).
    pub max_operations: u64,
    /// Nested function calls.
    pub max_call_depth: usize,
    /// Bytes in one string.
    pub max_string_size: usize,
    /// Items in one array.
    pub max_array_size: usize,
    /// Entries in one object map.
    pub max_map_size: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_memory: crate::memory::default_limit(),
            // NOTE: one quick oedometer sample takes under 2e4 operations (the physics runs
            // natively; a script loops over stages and balance chunks, not particles), so the
            // full run stays far inside this, and an endless loop stops in about 3 s.
            max_operations: 50_000_000,
            max_call_depth: 64,
            max_string_size: 16 << 20,
            max_array_size: 10_000_000,
            max_map_size: 100_000,
        }
    }
}

impl Limits {
    /// Sets every limit on `engine` and the process's memory limit. Rhai's own size checks
    /// are on, as needed to compile a script (they refuse literals that are too large); see
    /// [`Limits::running`] for running one.
    pub fn apply(&self, engine: &mut Engine) {
        engine.set_max_operations(self.max_operations);
        engine.set_max_call_levels(self.max_call_depth);
        engine.set_max_expr_depths(128, 64);
        crate::memory::set_limit(self.max_memory);
        size_checks::install(engine, *self);
        self.compiling(engine);
    }

    /// Rhai's own size checks on: for compiling a script.
    pub fn compiling(&self, engine: &mut Engine) {
        engine.set_max_string_size(self.max_string_size);
        engine.set_max_array_size(self.max_array_size);
        engine.set_max_map_size(self.max_map_size);
    }

    /// Rhai's own size checks off while a compiled script runs: they walk a whole array after
    /// every call on it; [`size_checks`] keeps the same limits at a bounded cost.
    pub fn running(&self, engine: &mut Engine) {
        engine.set_max_string_size(0);
        engine.set_max_array_size(0);
        engine.set_max_map_size(0);
    }
}

/// Serves `import "name"` from the script's read root (`name.rhai`), after the stdlib.
pub struct SandboxModules {
    pub root: ReadRoot,
    pub stdlib: StaticModuleResolver,
}

impl ModuleResolver for SandboxModules {
    fn resolve(
        &self,
        engine: &Engine,
        source: Option<&str>,
        path: &str,
        pos: Position,
    ) -> Result<Shared<Module>, Box<EvalAltResult>> {
        if self.stdlib.contains_path(path) {
            return self.stdlib.resolve(engine, source, path, pos);
        }
        let file = if path.ends_with(".rhai") { path.to_string() } else { format!("{path}.rhai") };
        let bytes = self.root.read(&file).map_err(|msg| {
            // A misspelt stdlib module reads as a missing file of the script's folder: say so.
            let msg = if path.starts_with("std/") {
                let known: Vec<&str> = crate::stdlib::SCRIPTS.iter().map(|(name, _)| *name).collect();
                format!(
                    "{msg}; no stdlib module is called `{path}`{}: the stdlib's are {}",
                    matdem_engine::error::did_you_mean(path, &known),
                    known.join(", ")
                )
            } else {
                msg
            };
            EvalAltResult::ErrorRuntime(msg.into(), pos)
        })?;
        let text = String::from_utf8(bytes)
            .map_err(|_| EvalAltResult::ErrorRuntime(format!("module `{file}` is not UTF-8 text").into(), pos))?;
        let mut ast = engine.compile(&text).map_err(|e| Box::new(EvalAltResult::from(e)))?;
        ast.set_source(path);
        let module = Module::eval_ast_as_new(Scope::new(), &ast, engine)
            .map_err(|e| Box::new(EvalAltResult::ErrorInModule(path.to_string(), e, pos)))?;
        Ok(module.into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_inside_the_root_pass_and_escapes_are_named() {
        assert_eq!(relative_parts("a/./b.csv").unwrap(), vec!["a", "b.csv"]);
        assert_eq!(relative_parts("../x").unwrap_err(), "`..` climbs out");
        assert_eq!(relative_parts("a/../../x").unwrap_err(), "`..` climbs out");
        assert_eq!(relative_parts("/etc/passwd").unwrap_err(), "an absolute path");
        assert!(relative_parts("").is_err());
        assert!(relative_parts(".").is_err());
    }
}
