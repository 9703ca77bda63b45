//! Interrupt and resume (`matdem-rs run SCRIPT --resume DIR`).
//!
//! A Rhai script cannot be frozen mid-way, so a resumed run *replays* it from the start.
//! For the replay to follow the same path, every call that lets the script see the
//! simulation — a run or balance and what it returned, a measured quantity, a lane such as
//! `d.z`, a record row — is written to a journal as it happens. On Ctrl-C or SIGTERM the
//! engine finishes its current chunk of steps, and the host writes, into `OUT/resume/`, a
//! checkpoint of every live model and the journal (last, so its presence means the folder is
//! whole), then exits with 130.
//!
//! On `--resume`, the script runs again with the same parameters; each journaled call
//! returns what it returned the first time instead of touching the models, and output
//! writes are skipped (those files were finished before the interruption). At the call that
//! was interrupted, every model is restored from its checkpoint, the rest of that call's
//! steps run, and from there on the script runs normally. The engine is deterministic on the
//! CPU backend, so the final outputs equal those of an uninterrupted run bit for bit.
//!
//! This module holds the journal, the resume folder and their checks. The script API's side
//! (a script's values as journal [`Value`]s, writing the resume point of a live run,
//! restoring it at the interrupted call) is `api::resume_point`, above it.

use crate::run_record::sha256_hex;
use matdem_engine::simulation::Balance;
use rhai::EvalAltResult;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The folder under a run's output folder that holds what a resume needs.
pub const RESUME_DIR: &str = "resume";
pub const JOURNAL_FILE: &str = "journal.ron";

/// A value a script saw, in a form that can be written down and given back bit for bit
/// (`Value::from_dynamic` and `Value::to_dynamic`, in `api::resume_point`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Value {
    Unit,
    Bool(bool),
    Int(i64),
    /// Stored as bits: RON prints NaNs and infinities, but bits are exact by construction.
    Float(u64),
    Str(String),
    Field(Vec<u64>),
    Mask(Vec<bool>),
    Array(Vec<Value>),
    Map(Vec<(String, Value)>),
    /// The call failed with this message (a script may catch it).
    Error(String),
}

/// One observed call: its name and what it gave the script.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    pub call: String,
    pub value: Value,
}

/// How far the interrupted run or balance had got.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Interrupted {
    /// The call's name (`run`, `balance`, …) and its position in the journal.
    pub call: String,
    pub index: usize,
    /// The run as the engine saw it (a standard balance already turned into its step count).
    pub how: SavedBalance,
    /// Steps it had completed.
    pub done: u64,
    /// Creation numbers of the models saved beside the journal (`model_<n>.mdem`).
    pub models: Vec<usize>,
}

/// [`Balance`] in a form that can be saved.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum SavedBalance {
    Steps(u64),
    Tolerance { ratio_bits: u64, max_steps: u64 },
}

impl SavedBalance {
    pub fn from_balance(b: Balance) -> Option<Self> {
        match b {
            Balance::Steps(n) => Some(SavedBalance::Steps(n)),
            Balance::Tolerance { ratio, max_steps } => {
                Some(SavedBalance::Tolerance { ratio_bits: ratio.to_bits(), max_steps })
            }
            Balance::Standard { .. } => None,
        }
    }

    pub fn to_balance(self) -> Balance {
        match self {
            SavedBalance::Steps(n) => Balance::Steps(n),
            SavedBalance::Tolerance { ratio_bits, max_steps } => {
                Balance::Tolerance { ratio: f64::from_bits(ratio_bits), max_steps }
            }
        }
    }
}

/// `OUT/resume/journal.ron`: what the interrupted run was and what its script saw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JournalFile {
    /// SHA-256 of the script, which must not change between the run and its resume.
    pub script_sha256: String,
    /// The `--set` parameters as given, name and text.
    pub params: Vec<(String, String)>,
    pub entries: Vec<Entry>,
    pub interrupted: Interrupted,
    /// The backend the run stepped on (`run.ron`'s words): a resume continues on the same one.
    #[serde(default)]
    pub backend: String,
    /// SHA-256 of each `model_<n>.mdem`, in the order of `interrupted.models`: a model file
    /// from another run (or another point of this one) is refused, not continued.
    #[serde(default)]
    pub model_sha256: Vec<String>,
}

/// The host's side of journaling: the entries so far and, while replaying, where it is.
#[derive(Default)]
pub struct Session {
    /// What a resume checks and reuses: the script's hash and the parameters as given.
    pub script_sha256: String,
    pub params: Vec<(String, String)>,
    /// The backend the run steps on, as `run.ron` words it.
    pub backend: String,
    pub entries: Vec<Entry>,
    /// Entries handed back so far while replaying.
    pub cursor: usize,
    /// Set while replaying a resumed run: what to restore at the interrupted call.
    pub pending: Option<Pending>,
}

/// What a resumed run restores when its replay reaches the interrupted call.
pub struct Pending {
    pub interrupted: Interrupted,
    pub models: Vec<(usize, matdem_engine::checkpoint::Checkpoint)>,
}

impl Session {
    pub fn replaying(&self) -> bool {
        self.pending.is_some()
    }

    /// The next journaled value for `call` while replaying; an error if the script has taken
    /// another path than the interrupted run (it changed, or reads something unjournaled).
    pub fn next(&mut self, call: &str) -> Result<Value, Box<EvalAltResult>> {
        match self.entries.get(self.cursor) {
            Some(e) if e.call == call => {
                self.cursor += 1;
                Ok(e.value.clone())
            }
            other => Err(diverged(self.cursor, call, other.map_or("the interrupted call", |e| e.call.as_str()))),
        }
    }
}

pub fn diverged(index: usize, got: &str, expected: &str) -> Box<EvalAltResult> {
    format!(
        "cannot resume: at its model call #{index} the script calls `{got}` where the interrupted run called \
         `{expected}`; resume only with the script and parameters that were interrupted, or start a fresh run"
    )
    .into()
}

/// The resume folder of run folder `out_dir`.
pub fn resume_dir(out_dir: &Path) -> PathBuf {
    out_dir.join(RESUME_DIR)
}

pub fn model_file(dir: &Path, n: usize) -> PathBuf {
    dir.join(format!("model_{n}.mdem"))
}

/// Writes the journal last: a resume folder without it is incomplete and refused.
pub fn write_journal(dir: &Path, journal: &JournalFile) -> std::io::Result<()> {
    let text = ron::ser::to_string_pretty(journal, ron::ser::PrettyConfig::default().compact_arrays(true))
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    crate::atomic_write::write(&dir.join(JOURNAL_FILE), text.as_bytes())
}

/// The run folder of `--resume DIR`, where DIR is the run's output folder or its `resume`
/// folder.
pub fn run_folder(dir: &Path) -> PathBuf {
    if dir.join(JOURNAL_FILE).is_file() {
        dir.parent().map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."))
    } else {
        dir.to_path_buf()
    }
}

/// Reads what `--resume DIR` needs. Returns the journal and the models, or a message saying
/// what to do.
pub fn load(dir: &Path) -> Result<(JournalFile, Vec<(usize, matdem_engine::checkpoint::Checkpoint)>), String> {
    let rdir = resume_dir(&run_folder(dir));
    let jpath = rdir.join(JOURNAL_FILE);
    let text = std::fs::read_to_string(&jpath).map_err(|e| {
        format!(
            "error: cannot resume from {}: no readable {} ({e}); give the output folder of an interrupted run \
             (it holds resume/{JOURNAL_FILE})",
            dir.display(),
            jpath.display()
        )
    })?;
    let journal: JournalFile = ron::from_str(&text).map_err(|e| {
        format!("error: {} is damaged ({e}); the interrupted run cannot be resumed, start a fresh run", jpath.display())
    })?;
    let refuse = |what: String| {
        format!(
            "error: cannot resume from {}: {what}; the resume folder was changed after the run wrote it (or comes \
             from another run): start a fresh run",
            dir.display()
        )
    };
    let sealed = sealed_journal_sha256(&run_folder(dir)).map_err(&refuse)?;
    if sealed != sha256_hex(text.as_bytes()) {
        return Err(refuse(format!("{} is not the journal its run.ron seals", jpath.display())));
    }
    let it = &journal.interrupted;
    let total = match it.how {
        SavedBalance::Steps(n) => n,
        SavedBalance::Tolerance { max_steps, .. } => max_steps,
    };
    if it.done > total || it.index > journal.entries.len() {
        return Err(refuse(format!("its interrupted `{}` did {} of {total} step(s)", it.call, it.done)));
    }
    if journal.model_sha256.len() != it.models.len() {
        return Err(refuse(format!("{} model file(s) for {} digest(s)", it.models.len(), journal.model_sha256.len())));
    }
    let mut models = Vec::new();
    for (&n, digest) in it.models.iter().zip(&journal.model_sha256) {
        let path = model_file(&rdir, n);
        let bytes = std::fs::read(&path).map_err(|e| format!("error: cannot read {}: {e}", path.display()))?;
        if sha256_hex(&bytes) != *digest {
            return Err(refuse(format!("{} is not the model its journal names", path.display())));
        }
        let ck = matdem_engine::checkpoint::decode(&bytes)
            .map_err(|e| format!("error: cannot resume from {}: {e}", path.display()))?;
        models.push((n, ck));
    }
    Ok((journal, models))
}

/// The journal digest `run.ron` keeps for an interrupted run (see [`crate::run_record`]).
fn sealed_journal_sha256(run_dir: &Path) -> Result<String, String> {
    #[derive(Deserialize)]
    struct Seal {
        #[serde(default)]
        resume_journal_sha256: Option<String>,
    }
    let path = run_dir.join(crate::run_record::RUN_RECORD);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let seal: Seal = ron::from_str(&text).map_err(|e| format!("{} is damaged ({e})", path.display()))?;
    seal.resume_journal_sha256.ok_or_else(|| format!("{} seals no resume journal", path.display()))
}

/// The digest [`load`] checks against the journal, for `run.ron` of an interrupted run.
pub fn journal_sha256(out_dir: &Path) -> Option<String> {
    std::fs::read(resume_dir(out_dir).join(JOURNAL_FILE)).ok().map(|b| sha256_hex(&b))
}
