//! Options maps (`#{ max_steps: 1000 }`): a key a procedure does not read is a typo that would
//! otherwise be dropped without a word (`sediment(d, #{ max_step: 100 })` ran its default
//! 200,000 steps). Native functions check their maps with [`check_keys`]; the stdlib's
//! procedures, and a script's own, with `check_options`.

use super::err;
use super::RhaiResult;
use rhai::{Array, Dynamic, Engine, Map};

/// Refuses a key of `map` not in `known`, naming the nearest known key and listing them.
pub fn check_keys(map: &Map, known: &[&str], what: &str) -> RhaiResult<()> {
    refuse_unknown(map, known, what, "key")
}

/// As [`check_keys`], the refusal calling a key `kind` ("key", "option").
fn refuse_unknown(map: &Map, known: &[&str], what: &str, kind: &'static str) -> RhaiResult<()> {
    for k in map.keys() {
        if !known.contains(&k.as_str()) {
            let e = matdem_engine::Error::unknown(kind, k, known);
            return Err(err(format!("{what}: {e}")));
        }
    }
    Ok(())
}

pub fn register(engine: &mut Engine) {
    engine.register_fn("check_options", |opts: Dynamic, known: Array, what: &str| -> RhaiResult<Dynamic> {
        let what = crate::terminal_text::one_line(what);
        if opts.is_unit() {
            return Ok(Dynamic::UNIT);
        }
        let Some(map) = opts.clone().try_cast::<Map>() else {
            return Err(err(format!("{what}: its options are a map, #{{ key: value, … }}; got {}", opts.type_name())));
        };
        let known: Vec<String> = known
            .into_iter()
            .map(|k| k.into_string().map_err(|t| err(format!("check_options: the known keys are strings; got {t}"))))
            .collect::<Result<_, _>>()?;
        let known: Vec<&str> = known.iter().map(String::as_str).collect();
        refuse_unknown(&map, &known, &what, "option")?;
        Ok(Dynamic::UNIT)
    });
}
