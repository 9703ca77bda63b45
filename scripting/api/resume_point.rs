//! The script API's side of interrupt and resume (see [`crate::resume`]): a script's values
//! turned into the journal's [`Value`]s and back, the resume folder written when a run or
//! balance is interrupted, and the models put back at the interrupted call of a resumed run.

use super::arrays::{Field, Mask};
use super::Host;
use crate::resume::{
    diverged, model_file, resume_dir, write_journal, Interrupted, JournalFile, SavedBalance, Value, JOURNAL_FILE,
};
use crate::run_record::sha256_hex;
use matdem_engine::simulation::Balance;
use rhai::{Array, Dynamic, EvalAltResult, Map};
use std::path::PathBuf;

// `resume::Value`'s conversions live here, beside the script types they name (`Field`, `Mask`).
impl Value {
    /// `None` for a type the journal does not know (a host bug: the caller says which call).
    pub fn from_dynamic(v: &Dynamic) -> Option<Value> {
        if v.is_unit() {
            return Some(Value::Unit);
        }
        if let Ok(b) = v.as_bool() {
            return Some(Value::Bool(b));
        }
        if let Ok(i) = v.as_int() {
            return Some(Value::Int(i));
        }
        if let Ok(x) = v.as_float() {
            return Some(Value::Float(x.to_bits()));
        }
        if let Some(s) = v.clone().try_cast::<rhai::ImmutableString>() {
            return Some(Value::Str(s.to_string()));
        }
        if let Some(f) = v.clone().try_cast::<Field>() {
            return Some(Value::Field(f.0.iter().map(|x| x.to_bits()).collect()));
        }
        if let Some(m) = v.clone().try_cast::<Mask>() {
            return Some(Value::Mask(m.0.to_vec()));
        }
        if let Some(a) = v.clone().try_cast::<Array>() {
            return a.iter().map(Value::from_dynamic).collect::<Option<Vec<_>>>().map(Value::Array);
        }
        if let Some(m) = v.clone().try_cast::<Map>() {
            return m
                .iter()
                .map(|(k, v)| Value::from_dynamic(v).map(|v| (k.to_string(), v)))
                .collect::<Option<Vec<_>>>()
                .map(Value::Map);
        }
        None
    }

    pub fn to_dynamic(&self) -> Result<Dynamic, Box<EvalAltResult>> {
        Ok(match self {
            Value::Unit => Dynamic::UNIT,
            Value::Bool(b) => Dynamic::from_bool(*b),
            Value::Int(i) => Dynamic::from_int(*i),
            Value::Float(bits) => Dynamic::from_float(f64::from_bits(*bits)),
            Value::Str(s) => Dynamic::from(s.clone()),
            Value::Field(v) => Dynamic::from(Field::new(v.iter().map(|b| f64::from_bits(*b)).collect())),
            Value::Mask(v) => Dynamic::from(Mask::new(v.clone())),
            Value::Array(a) => Dynamic::from_array(a.iter().map(Value::to_dynamic).collect::<Result<_, _>>()?),
            Value::Map(m) => {
                let mut map = Map::new();
                for (k, v) in m {
                    map.insert(k.as_str().into(), v.to_dynamic()?);
                }
                Dynamic::from_map(map)
            }
            Value::Error(msg) => return Err(msg.clone().into()),
        })
    }
}

/// Writes the resume folder of an interrupted run: a checkpoint of every live model, then
/// the journal. Returns the folder.
pub fn write_resume(host: &Host, call: &str, how: SavedBalance, done: u64) -> Result<PathBuf, String> {
    let dir = resume_dir(&host.out_dir);
    let (mut numbers, mut digests) = (Vec::new(), Vec::new());
    for (n, weak) in host.models.borrow().iter().enumerate() {
        if let Some(data) = weak.upgrade() {
            let path = model_file(&dir, n);
            let bytes = super::checkpoint::checkpoint_bytes(&data.borrow());
            crate::atomic_write::write(&path, &bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            numbers.push(n);
            digests.push(sha256_hex(&bytes));
        }
    }
    let s = host.session.borrow();
    let journal = JournalFile {
        script_sha256: s.script_sha256.clone(),
        params: s.params.clone(),
        entries: s.entries.clone(),
        interrupted: Interrupted { call: call.to_string(), index: s.entries.len(), how, done, models: numbers },
        backend: s.backend.clone(),
        model_sha256: digests,
    };
    write_journal(&dir, &journal).map_err(|e| format!("cannot write {}: {e}", dir.join(JOURNAL_FILE).display()))?;
    Ok(dir)
}

/// At the interrupted call of a resumed run: puts every saved model back and ends the
/// replay. Returns what remains to run of that call. `asked` is what the script asks of the
/// call now: a run of a given length or tolerance must be the one the journal says was cut.
pub fn restore(host: &Host, call: &str, asked: Balance) -> Result<(Balance, u64), Box<EvalAltResult>> {
    let pending = {
        let mut s = host.session.borrow_mut();
        let Some(p) = s.pending.take() else {
            return Err("internal error: nothing to restore; please report this bug".into());
        };
        if p.interrupted.call != call || s.cursor != p.interrupted.index {
            return Err(diverged(s.cursor, call, &p.interrupted.call));
        }
        // A standard balance's count came from the model as it was then; the sealed journal
        // vouches for it (see `load`).
        let same = match asked {
            Balance::Standard { .. } => matches!(p.interrupted.how, SavedBalance::Steps(_)),
            other => SavedBalance::from_balance(other) == Some(p.interrupted.how),
        };
        if !same {
            return Err(format!(
                "cannot resume: the script asks its `{call}` for {asked:?}, the interrupted run's was {:?}; resume \
                 only with the script and parameters that were interrupted, or start a fresh run",
                p.interrupted.how
            )
            .into());
        }
        p
    };
    let models = host.models.borrow();
    for (n, ck) in pending.models {
        let data = models.get(n).and_then(|w| w.upgrade()).ok_or_else(|| -> Box<EvalAltResult> {
            format!(
                "cannot resume: model #{n} of the interrupted run does not exist at this point of the script; resume \
                 only with the script and parameters that were interrupted, or start a fresh run"
            )
            .into()
        })?;
        super::checkpoint::restore(&mut data.borrow_mut(), ck)
            .map_err(|e| -> Box<EvalAltResult> { format!("cannot resume: model #{n}: {e}").into() })?;
    }
    Ok((pending.interrupted.how.to_balance(), pending.interrupted.done))
}
