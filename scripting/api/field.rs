//! Whole-array values (MatDEM works on matrices): `Field` holds one number per particle (or
//! per row of a table), `Mask` one boolean. Arithmetic, comparisons and reductions run
//! natively, so a script never needs a per-particle loop.

use super::{err, RhaiResult};
use rhai::{Array, Dynamic, Engine, FLOAT, INT};
use std::rc::Rc;

/// The most values a field made by a script may hold (as many as the largest box's particles).
const MAX_FIELD_LEN: INT = matdem_engine::builder::MAX_BOX_PARTICLES as INT;

/// Numbers, one per particle or row. Cheap to clone (shared, copy on write).
#[derive(Debug, Clone, Default)]
pub struct Field(pub Rc<Vec<f64>>);

/// Booleans, one per particle or row, from comparisons of fields.
#[derive(Debug, Clone, Default)]
pub struct Mask(pub Rc<Vec<bool>>);

impl Field {
    pub fn new(v: Vec<f64>) -> Self {
        Field(Rc::new(v))
    }

    fn zip(&self, o: &Field, op: &str, f: impl Fn(f64, f64) -> f64) -> RhaiResult<Field> {
        if self.0.len() != o.0.len() {
            return Err(err(format!(
                "cannot apply `{op}` to arrays of different lengths ({} and {})",
                self.0.len(),
                o.0.len()
            )));
        }
        Ok(Field::new(self.0.iter().zip(o.0.iter()).map(|(a, b)| f(*a, *b)).collect()))
    }

    fn map(&self, f: impl Fn(f64) -> f64) -> Field {
        Field::new(self.0.iter().map(|a| f(*a)).collect())
    }

    fn cmp(&self, o: &Field, op: &str, f: impl Fn(f64, f64) -> bool) -> RhaiResult<Mask> {
        if self.0.len() != o.0.len() {
            return Err(err(format!(
                "cannot compare arrays of different lengths with `{op}` ({} and {})",
                self.0.len(),
                o.0.len()
            )));
        }
        Ok(Mask(Rc::new(self.0.iter().zip(o.0.iter()).map(|(a, b)| f(*a, *b)).collect())))
    }

    fn cmp_scalar(&self, s: f64, f: impl Fn(f64, f64) -> bool) -> Mask {
        Mask(Rc::new(self.0.iter().map(|a| f(*a, s)).collect()))
    }

    /// Elements where `mask` is true.
    pub fn select(&self, mask: &Mask) -> RhaiResult<Field> {
        if self.0.len() != mask.0.len() {
            return Err(err(format!("mask length {} does not match array length {}", mask.0.len(), self.0.len())));
        }
        Ok(Field::new(self.0.iter().zip(mask.0.iter()).filter(|(_, m)| **m).map(|(v, _)| *v).collect()))
    }

    /// Elements at the given 0-based indices.
    pub fn pick(&self, ids: &[usize]) -> RhaiResult<Field> {
        let n = self.0.len();
        ids.iter()
            .map(|&i| self.0.get(i).copied().ok_or_else(|| err(format!("index {i} out of range 0..{n}"))))
            .collect::<RhaiResult<Vec<f64>>>()
            .map(Field::new)
    }

    pub fn mean(&self) -> f64 {
        if self.0.is_empty() {
            f64::NAN
        } else {
            self.0.iter().sum::<f64>() / self.0.len() as f64
        }
    }
}

/// Converts a script value (Field, array of numbers or a number) to numbers.
pub fn to_numbers(v: &Dynamic, what: &str) -> RhaiResult<Vec<f64>> {
    if let Some(f) = v.clone().try_cast::<Field>() {
        return Ok(f.0.to_vec());
    }
    if let Some(a) = v.clone().try_cast::<Array>() {
        return a
            .iter()
            .enumerate()
            .map(|(k, x)| {
                number(x).ok_or_else(|| err(format!("{what}: element {k} is a {}, expected a number", x.type_name())))
            })
            .collect();
    }
    Err(err(format!("{what}: expected an array of numbers, got {}", v.type_name())))
}

/// A number from an INT or FLOAT.
pub fn number(v: &Dynamic) -> Option<f64> {
    v.as_float().ok().or_else(|| v.as_int().ok().map(|i| i as f64))
}

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<Field>("Field").register_type_with_name::<Mask>("Mask");
    engine
        .register_fn("field", |a: Array| to_numbers(&Dynamic::from_array(a), "field").map(Field::new))
        .register_fn("zeros", |n: INT| -> RhaiResult<Field> {
            // A field is a whole-model array: cap it where memory, not the script, would fail.
            if !(0..=MAX_FIELD_LEN).contains(&n) {
                return Err(err(format!("zeros({n}): a field holds 0 to {MAX_FIELD_LEN} values")));
            }
            Ok(Field::new(vec![0.0; n as usize]))
        })
        .register_fn("len", |f: &mut Field| f.0.len() as INT)
        .register_get("len", |f: &mut Field| f.0.len() as INT)
        .register_fn("sum", |f: &mut Field| f.0.iter().sum::<f64>())
        .register_fn("mean", |f: &mut Field| f.mean())
        .register_fn("max", |f: &mut Field| f.0.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        .register_fn("min", |f: &mut Field| f.0.iter().copied().fold(f64::INFINITY, f64::min))
        .register_fn("abs", |f: &mut Field| f.map(f64::abs))
        .register_fn("sqrt", |f: &mut Field| f.map(f64::sqrt))
        .register_fn("to_array", |f: &mut Field| f.0.iter().map(|v| Dynamic::from_float(*v)).collect::<Array>())
        .register_fn("select", |f: &mut Field, m: Mask| f.select(&m))
        .register_fn("fmt", |x: FLOAT, decimals: INT| format!("{x:.*}", decimals.clamp(0, 17) as usize))
        .register_fn("fmt", |x: INT, _decimals: INT| x.to_string())
        .register_fn("to_string", |f: &mut Field| summary(&f.0))
        .register_fn("to_debug", |f: &mut Field| summary(&f.0))
        .register_indexer_get(|f: &mut Field, i: INT| -> RhaiResult<FLOAT> {
            f.0.get(i as usize)
                .copied()
                .filter(|_| i >= 0)
                .ok_or_else(|| err(format!("index {i} out of range 0..{}", f.0.len())))
        });
    macro_rules! arith {
        ($op:literal, $f:expr) => {
            engine
                .register_fn($op, |a: Field, b: Field| a.zip(&b, $op, $f))
                .register_fn($op, |a: Field, b: FLOAT| a.map(|x| $f(x, b)))
                .register_fn($op, |a: FLOAT, b: Field| b.map(|x| $f(a, x)))
                .register_fn($op, |a: Field, b: INT| a.map(|x| $f(x, b as f64)))
                .register_fn($op, |a: INT, b: Field| b.map(|x| $f(a as f64, x)));
        };
    }
    arith!("+", |a: f64, b: f64| a + b);
    arith!("-", |a: f64, b: f64| a - b);
    arith!("*", |a: f64, b: f64| a * b);
    arith!("/", |a: f64, b: f64| a / b);
    engine.register_fn("-", |a: Field| a.map(|x| -x));
    macro_rules! compare {
        ($op:literal, $f:expr) => {
            engine
                .register_fn($op, |a: Field, b: Field| a.cmp(&b, $op, $f))
                .register_fn($op, |a: Field, b: FLOAT| a.cmp_scalar(b, $f))
                .register_fn($op, |a: Field, b: INT| a.cmp_scalar(b as f64, $f));
        };
    }
    compare!("<", |a: f64, b: f64| a < b);
    compare!("<=", |a: f64, b: f64| a <= b);
    compare!(">", |a: f64, b: f64| a > b);
    compare!(">=", |a: f64, b: f64| a >= b);
    engine
        .register_fn("&", |a: Mask, b: Mask| mask_zip(&a, &b, |x, y| x && y))
        .register_fn("|", |a: Mask, b: Mask| mask_zip(&a, &b, |x, y| x || y))
        .register_fn("!", |a: Mask| Mask(Rc::new(a.0.iter().map(|x| !x).collect())))
        .register_fn("count", |m: &mut Mask| m.0.iter().filter(|x| **x).count() as INT)
        .register_fn("len", |m: &mut Mask| m.0.len() as INT)
        .register_fn("ids", |m: &mut Mask| {
            m.0.iter().enumerate().filter(|(_, x)| **x).map(|(i, _)| Dynamic::from_int(i as INT)).collect::<Array>()
        })
        .register_fn("to_string", |m: &mut Mask| {
            format!("Mask({} of {} true)", m.0.iter().filter(|x| **x).count(), m.0.len())
        })
        .register_fn("to_debug", |m: &mut Mask| {
            format!("Mask({} of {} true)", m.0.iter().filter(|x| **x).count(), m.0.len())
        });
}

fn mask_zip(a: &Mask, b: &Mask, f: impl Fn(bool, bool) -> bool) -> RhaiResult<Mask> {
    if a.0.len() != b.0.len() {
        return Err(err(format!("cannot combine masks of lengths {} and {}", a.0.len(), b.0.len())));
    }
    Ok(Mask(Rc::new(a.0.iter().zip(b.0.iter()).map(|(x, y)| f(*x, *y)).collect())))
}

fn summary(v: &[f64]) -> String {
    let head: Vec<String> = v.iter().take(6).map(|x| format!("{x:.6e}")).collect();
    let more = if v.len() > 6 { ", …" } else { "" };
    format!("Field[{}]({}{more})", v.len(), head.join(", "))
}
