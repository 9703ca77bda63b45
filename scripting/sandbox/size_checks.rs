//! The sandbox's limits on strings, arrays and object maps while a script runs: checked
//! where the script reaches a value (each read of a variable), at a cost that does not grow
//! with the value.
//!
//! Rhai's own check, once any size limit is set, walks the whole receiver of every method
//! call after the call (`calc_data_sizes` visits every element, recursively): `a.push(x)` and
//! even `a.len()` cost O(len), so 100,000 pushes took 5.1 s and 100,000 `a.len()` on a
//! 100,000-item array 10.7 s, far longer than the operation limit suggests. And its index
//! assignment checks only the value assigned, never the map it goes into, so a loop of
//! `m[k] = v` grew a map past `--max-map-size` without bound.
//!
//! So Rhai's limits are on while a script is compiled (literals that are too large are
//! refused as they are parsed) and off while it runs; instead every read of a variable
//! checks that variable's own length (O(1)), and a walk of everything it holds (nested
//! arrays and maps, strings inside) runs only when the reads of that variable since its
//! previous walk have paid for it: a walk visiting n values is followed by n reads without
//! one, so walks cost amortised O(1) a read. A value that grows in a loop is read in the
//! loop, so it is refused within one turn of passing a limit (what is nested in it within a
//! few turns); fields, tables and charts are bounded by `--max-memory` ([`crate::memory`]).
//!
//! Rhai's `pad` and `blob` constructors read the engine's limits to refuse a size before
//! allocating it; with those off they would allocate anything, so they are replaced here by
//! the same functions that read the sandbox's limits and allocate with `try_reserve`.

use super::Limits;
use rhai::{Array, Blob, Dynamic, Engine, EvalAltResult, FuncRegistration, ImmutableString, Position, INT};
use std::cell::RefCell;
use std::collections::HashMap;

/// Rhai's functions replaced here, for the script reference.
pub const DOCS: &[(&str, &str, &str)] = &[
    ("pad", "a.pad(len, value) / s.pad(len, char or string) / b.pad(len, byte)", "Rhai's pad (arrays, strings, BLOBs), refusing a length over --max-array-size or --max-string-size before allocating it"),
    ("blob", "blob(len) / blob(len, byte) -> BLOB", "Rhai's BLOB of len bytes, refusing a length over --max-array-size before allocating it"),
];

/// How deep a walk looks into nested arrays and maps (deeper values are counted as one).
const MAX_WALK_DEPTH: usize = 64;

/// Sizes as Rhai counts them: array items (nested ones too; a BLOB's bytes), map entries
/// (nested ones too), string bytes (every string inside); and how many values were visited.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct Sizes {
    arrays: usize,
    maps: usize,
    strings: usize,
    visited: usize,
}

/// The first limit `sizes` pass, as Rhai's error (so messages name the flag to raise).
fn over(sizes: Sizes, limits: &Limits) -> Result<(), Box<EvalAltResult>> {
    if sizes.strings > limits.max_string_size {
        return Err(too_large("Length of string"));
    }
    if sizes.arrays > limits.max_array_size {
        return Err(too_large("Size of array/BLOB"));
    }
    if sizes.maps > limits.max_map_size {
        return Err(too_large("Size of object map"));
    }
    Ok(())
}

/// The length of `v` itself (not of what it holds).
fn own(v: &Dynamic) -> Sizes {
    let mut s = Sizes::default();
    if v.is_array() {
        s.arrays = v.as_array_ref().map_or(0, |a| a.len());
    } else if v.is_map() {
        s.maps = v.as_map_ref().map_or(0, |m| m.len());
    } else if v.is_string() {
        s.strings = v.as_immutable_string_ref().map_or(0, |t| t.len());
    } else if v.is_blob() {
        s.arrays = v.as_blob_ref().map_or(0, |b| b.len());
    }
    s
}

/// Adds the sizes of `v` and of everything it holds to `s`.
fn walk(v: &Dynamic, s: &mut Sizes, depth: usize) {
    s.visited += 1;
    if v.is_array() {
        if let Ok(a) = v.as_array_ref() {
            walk_items(a.iter(), a.len(), s, depth);
        }
    } else if v.is_map() {
        if let Ok(m) = v.as_map_ref() {
            s.maps += m.len();
            if depth < MAX_WALK_DEPTH {
                m.values().for_each(|x| walk(x, s, depth + 1));
            }
        }
    } else {
        let own = own(v);
        s.arrays += own.arrays;
        s.strings += own.strings;
    }
}

/// Adds the sizes of an array's `len` items to `s`.
fn walk_items<'a>(items: impl Iterator<Item = &'a Dynamic>, len: usize, s: &mut Sizes, depth: usize) {
    s.arrays += len;
    if depth < MAX_WALK_DEPTH {
        items.for_each(|x| walk(x, s, depth + 1));
    }
}

/// Installs the checks on every read of a variable and the checked `pad` and `blob`.
/// `limits` are the sandbox's, whatever Rhai's are set to.
pub fn install(engine: &mut Engine, limits: Limits) {
    // Per variable name: the reads since its last walk, and how many values that walk
    // visited. Kept per name: with one count for all, a loop reading a small and a large
    // value in turn can fall into step with it and walk only the small one.
    let walks: RefCell<HashMap<String, (usize, usize)>> = RefCell::default();
    #[allow(deprecated)] // NOTE: `on_var` is marked volatile, not deprecated.
    engine.on_var(move |name, _, context| {
        let Some(v) = context.scope().get(name) else { return Ok(None) };
        over(own(v), &limits)?;
        // A string's own length is all it holds; a number holds nothing.
        if !(v.is_array() || v.is_map()) {
            return Ok(None);
        }
        let mut walks = walks.borrow_mut();
        let due = match walks.get_mut(name) {
            Some((reads, cost)) => {
                *reads += 1;
                *reads >= *cost
            }
            None => true,
        };
        if due {
            let mut sizes = Sizes::default();
            walk(v, &mut sizes, 0);
            over(sizes, &limits)?;
            walks.insert(name.to_string(), (0, sizes.visited));
        }
        Ok(None)
    });
    register_bulk_constructors(engine, limits);
}

fn too_large(what: &str) -> Box<EvalAltResult> {
    EvalAltResult::ErrorDataTooLarge(what.into(), Position::NONE).into()
}

/// The error for a size the system cannot give (`try_reserve` failed).
fn no_memory(what: &str) -> Box<EvalAltResult> {
    format!("{what}: the system cannot give the memory for it; ask for less").into()
}

/// Rhai's `pad` (arrays, BLOBs, strings) and `blob(n)`, refusing a length over the sandbox's
/// limits before allocating it.
fn register_bulk_constructors(engine: &mut Engine, limits: Limits) {
    type Checked = Result<(), Box<EvalAltResult>>;
    let (max_array, max_string) = (limits.max_array_size, limits.max_string_size);
    // `pad` changes its receiver: not pure, so calling it on a constant is refused as Rhai's is.
    let pad = || FuncRegistration::new("pad").with_purity(false);
    pad().register_into_engine(engine, move |array: &mut Array, len: INT, item: Dynamic| -> Checked {
        let len = usize::try_from(len).unwrap_or(0);
        if len <= array.len() {
            return Ok(());
        }
        let added = len - array.len();
        let (mut now, mut each) = (Sizes::default(), Sizes::default());
        walk_items(array.iter(), array.len(), &mut now, 0);
        walk(&item, &mut each, 0);
        let after = Sizes {
            arrays: now.arrays.saturating_add(added.saturating_mul(each.arrays + 1)),
            maps: now.maps.saturating_add(added.saturating_mul(each.maps)),
            strings: now.strings.saturating_add(added.saturating_mul(each.strings)),
            visited: 0,
        };
        over(after, &limits)?;
        array.try_reserve_exact(added).map_err(|_| no_memory("pad"))?;
        array.resize(len, item);
        Ok(())
    });
    let blob_of = move |len: INT, value: INT| -> Result<Blob, Box<EvalAltResult>> {
        let len = usize::try_from(len).unwrap_or(0);
        if len > max_array {
            return Err(too_large("Size of array/BLOB"));
        }
        let mut b = Blob::new();
        b.try_reserve_exact(len).map_err(|_| no_memory("blob"))?;
        b.resize(len, (value & 0xff) as u8);
        Ok(b)
    };
    engine.register_fn("blob", move |len: INT| blob_of(len, 0)).register_fn("blob", blob_of);
    pad().register_into_engine(engine, move |blob: &mut Blob, len: INT, value: INT| -> Checked {
        let len = usize::try_from(len).unwrap_or(0);
        if len <= blob.len() {
            return Ok(());
        }
        if len > max_array {
            return Err(too_large("Size of array/BLOB"));
        }
        blob.try_reserve_exact(len - blob.len()).map_err(|_| no_memory("pad"))?;
        blob.resize(len, (value & 0xff) as u8);
        Ok(())
    });
    // Strings pad to `len` characters, repeating the padding (Rhai's semantics).
    let pad_string = move |string: &mut ImmutableString, len: INT, padding: &str| -> Checked {
        let len = usize::try_from(len).unwrap_or(0);
        if len > max_string {
            return Err(too_large("Length of string"));
        }
        let have = string.chars().count();
        if len <= have || padding.is_empty() {
            return Ok(());
        }
        let mut p = String::new();
        let per_char = padding.len().div_ceil(padding.chars().count());
        p.try_reserve_exact(string.len() + (len - have) * per_char).map_err(|_| no_memory("pad"))?;
        p.push_str(string);
        p.extend(padding.chars().cycle().take(len - have));
        if p.len() > max_string {
            return Err(too_large("Length of string"));
        }
        *string = p.into();
        Ok(())
    };
    pad().register_into_engine(engine, move |s: &mut ImmutableString, len: INT, c: char| {
        pad_string(s, len, c.encode_utf8(&mut [0; 4]))
    });
    pad().register_into_engine(engine, pad_string);
}
