//! Whole-array values (MatDEM works on matrices): `Field` holds one number per particle (or
//! per row of a table), `Mask` one boolean. Arithmetic, comparisons, element-wise functions
//! (`min max clamp abs sqrt exp ln log10 pow where`) and reductions run natively, so a script
//! never needs a per-particle loop.
//!
//! Numbers: field maths never makes a NaN or an infinity silently. An element-wise operation
//! whose finite operands would give one (a division by zero, the square root or logarithm of
//! a negative, an overflow) is refused, naming the first such element, its value and what to
//! do; a number operand must be finite. NaN already in a field (a table's missing value)
//! passes through element-wise maths unchanged. Reductions (`sum mean min max`) refuse a
//! NaN/inf element, naming it, and `mean min max` refuse an empty field.

use super::{err, RhaiResult};
use crate::memory::{self, Charge};
use rhai::{Array, Dynamic, Engine, FLOAT, INT};
use std::ops::Deref;
use std::rc::Rc;

/// The most values a field made by a script may hold (as many as the largest box's particles).
const MAX_FIELD_LEN: INT = matdem_engine::builder::MAX_BOX_PARTICLES as INT;

/// Values whose bytes count in the run's memory budget while they live (see
/// [`crate::memory`]): the storage of a field or a mask.
#[derive(Debug, Default)]
pub struct Counted<T> {
    values: Vec<T>,
    _charge: Charge,
}

impl<T> Counted<T> {
    /// Counts values already made (the script stops at its next operation if they took the
    /// run over `--max-memory`).
    fn new(values: Vec<T>) -> Self {
        let bytes = (values.capacity() * std::mem::size_of::<T>()) as u64;
        Counted { values, _charge: Charge::counted(bytes) }
    }

    /// `n` values made by `fill`, refused before allocating when they would pass the
    /// memory limit (or the system cannot give them); `what` names the call.
    fn build(n: usize, what: &str, fill: impl FnOnce(&mut Vec<T>) -> RhaiResult<()>) -> RhaiResult<Self> {
        let (mut values, charge) = memory::vec_for(n, what).map_err(err)?;
        fill(&mut values)?;
        Ok(Counted { values, _charge: charge })
    }
}

impl<T> Deref for Counted<T> {
    type Target = Vec<T>;

    fn deref(&self) -> &Vec<T> {
        &self.values
    }
}

/// Numbers, one per particle or row. Cheap to clone (shared, copy on write).
#[derive(Debug, Clone, Default)]
pub struct Field(pub Rc<Counted<f64>>);

/// Booleans, one per particle or row, from comparisons of fields.
#[derive(Debug, Clone, Default)]
pub struct Mask(pub Rc<Counted<bool>>);

impl Mask {
    pub fn new(v: Vec<bool>) -> Self {
        Mask(Rc::new(Counted::new(v)))
    }

    /// `n` booleans from `values`, refused before allocating past the memory limit.
    fn collect(n: usize, what: &str, values: impl Iterator<Item = bool>) -> RhaiResult<Mask> {
        Counted::build(n, what, |v| {
            v.extend(values.take(n));
            Ok(())
        })
        .map(|c| Mask(Rc::new(c)))
    }
}

impl Field {
    pub fn new(v: Vec<f64>) -> Self {
        Field(Rc::new(Counted::new(v)))
    }

    /// `n` numbers from `values`, refused before allocating past the memory limit.
    pub fn collect(n: usize, what: &str, values: impl Iterator<Item = f64>) -> RhaiResult<Field> {
        Counted::build(n, what, |v| {
            v.extend(values.take(n));
            Ok(())
        })
        .map(|c| Field(Rc::new(c)))
    }

    fn cmp(&self, o: &Field, op: &str, f: impl Fn(f64, f64) -> bool) -> RhaiResult<Mask> {
        if self.0.len() != o.0.len() {
            return Err(err(format!(
                "cannot compare arrays of different lengths with `{op}` ({} and {})",
                self.0.len(),
                o.0.len()
            )));
        }
        Mask::collect(self.0.len(), op, self.0.iter().zip(o.0.iter()).map(|(a, b)| f(*a, *b)))
    }

    fn cmp_scalar(&self, s: f64, op: &str, f: impl Fn(f64, f64) -> bool) -> RhaiResult<Mask> {
        Mask::collect(self.0.len(), op, self.0.iter().map(|a| f(*a, s)))
    }

    /// Elements where `mask` is true.
    pub fn select(&self, mask: &Mask) -> RhaiResult<Field> {
        if self.0.len() != mask.0.len() {
            return Err(err(format!("mask length {} does not match array length {}", mask.0.len(), self.0.len())));
        }
        let n = mask.0.iter().filter(|m| **m).count();
        Field::collect(n, "select", self.0.iter().zip(mask.0.iter()).filter(|(_, m)| **m).map(|(v, _)| *v))
    }

    /// Elements at the given 0-based indices.
    pub fn pick(&self, ids: &[usize]) -> RhaiResult<Field> {
        let n = self.0.len();
        Counted::build(ids.len(), "pick", |out| {
            for &i in ids {
                out.push(self.0.get(i).copied().ok_or_else(|| err(format!("index {i} out of range 0..{n}")))?);
            }
            Ok(())
        })
        .map(|c| Field(Rc::new(c)))
    }

    /// `f(x)` of every element; refuses (naming the first element, with `why(x)`) a result
    /// that is NaN or infinite where `x` was finite.
    fn unary(&self, op: &str, f: impl Fn(f64) -> f64, why: impl Fn(f64) -> String) -> RhaiResult<Field> {
        let out = Field::collect(self.0.len(), op, self.0.iter().map(|&x| f(x)))?;
        match out.0.iter().zip(self.0.iter()).position(|(y, x)| !y.is_finite() && x.is_finite()) {
            Some(i) => Err(err(format!("{op}: element {i} {}", why(self.0[i])))),
            None => Ok(out),
        }
    }

    /// Checks that a reduction has finite values to work on.
    fn reducible(&self, what: &str) -> RhaiResult<()> {
        if self.0.is_empty() {
            return Err(err(format!(
                "{what} of an empty field (0 values): the selection is empty; check `mask.count() > 0` before taking its {what}"
            )));
        }
        self.all_finite(what)
    }

    fn all_finite(&self, what: &str) -> RhaiResult<()> {
        match self.0.iter().position(|x| !x.is_finite()) {
            Some(i) => Err(err(format!(
                "{what}: element {i} is {} (a missing or diverged value); take the {what} of the finite values: \
                 `f.select(f.is_finite()).{what}()`",
                show(self.0[i])
            ))),
            None => Ok(()),
        }
    }

    /// The sum; 0 for an empty field. Refuses non-finite elements and an overflowing sum.
    pub fn sum(&self) -> RhaiResult<f64> {
        self.all_finite("sum")?;
        let s: f64 = self.0.iter().sum();
        if s.is_finite() {
            Ok(s)
        } else {
            Err(err(format!(
                "sum: the sum of {} values overflows beyond ±{LARGEST}; rescale the values first (e.g. to MPa)",
                self.0.len()
            )))
        }
    }

    /// The mean. Refuses an empty field and non-finite elements.
    pub fn mean(&self) -> RhaiResult<f64> {
        self.reducible("mean")?;
        let n = self.0.len() as f64;
        let s: f64 = self.0.iter().sum();
        // NOTE: values near ±f64::MAX overflow the plain sum; their scaled sum cannot.
        Ok(if s.is_finite() { s / n } else { self.0.iter().map(|x| x / n).sum() })
    }

    /// The smallest value. Refuses an empty field and non-finite elements.
    pub fn min(&self) -> RhaiResult<f64> {
        self.reducible("min")?;
        Ok(self.0.iter().copied().fold(f64::INFINITY, f64::min))
    }

    /// The largest value. Refuses an empty field and non-finite elements.
    pub fn max(&self) -> RhaiResult<f64> {
        self.reducible("max")?;
        Ok(self.0.iter().copied().fold(f64::NEG_INFINITY, f64::max))
    }

    /// Each element clamped into `[lo, hi]`; NaN (a missing value) stays NaN.
    pub fn clamp(&self, lo: f64, hi: f64) -> RhaiResult<Field> {
        // NOTE: f64::clamp panics on a NaN bound or lo > hi: check first.
        if !(lo.is_finite() && hi.is_finite()) || lo > hi {
            return Err(err(format!(
                "clamp: the bounds must be finite numbers with lo ≤ hi, got lo = {}, hi = {}",
                show(lo),
                show(hi)
            )));
        }
        Field::collect(self.0.len(), "clamp", self.0.iter().map(|x| x.clamp(lo, hi)))
    }

    /// A mask of the elements that are finite numbers (not NaN or ±inf).
    pub fn is_finite(&self) -> RhaiResult<Mask> {
        Mask::collect(self.0.len(), "is_finite", self.0.iter().map(|x| x.is_finite()))
    }
}

/// One side of an element-wise operation: a field, or one number for every element.
#[derive(Debug, Clone)]
pub enum Operand {
    Values(Field),
    Number(f64),
}

impl Operand {
    /// A Field, a number (INT or FLOAT); a number must be finite.
    pub fn from_dynamic(v: &Dynamic, op: &str) -> RhaiResult<Operand> {
        if let Some(f) = v.clone().try_cast::<Field>() {
            return Ok(Operand::Values(f));
        }
        match number(v) {
            Some(x) if x.is_finite() => Ok(Operand::Number(x)),
            Some(x) => Err(err(format!("{}: the number {} is not finite; give a finite number", label(op), show(x)))),
            None => Err(err(format!("{}: expected a Field or a number, got {}", label(op), v.type_name()))),
        }
    }

    fn at(&self, i: usize) -> f64 {
        match self {
            Operand::Values(f) => f.0[i],
            Operand::Number(x) => *x,
        }
    }

    fn len(&self) -> Option<usize> {
        match self {
            Operand::Values(f) => Some(f.0.len()),
            Operand::Number(_) => None,
        }
    }
}

impl From<Field> for Operand {
    fn from(f: Field) -> Self {
        Operand::Values(f)
    }
}

impl From<f64> for Operand {
    fn from(x: f64) -> Self {
        Operand::Number(x)
    }
}

/// The common length of operands that are fields (`None`: all numbers).
fn common_len(op: &str, operands: &[&Operand]) -> RhaiResult<Option<usize>> {
    let mut n: Option<usize> = None;
    for len in operands.iter().filter_map(|o| o.len()) {
        match n {
            Some(m) if m != len => {
                return Err(err(format!("cannot apply `{op}` to arrays of different lengths ({m} and {len})")))
            }
            _ => n = Some(len),
        }
    }
    Ok(n)
}

/// `f(a, b)` element by element (a number applies to every element). Refuses, naming the
/// first element and `why(a, b)`, a result that is NaN or infinite where `a` and `b` were
/// finite: field maths never makes a NaN or an infinity silently.
pub fn binary(
    op: &str,
    a: &Operand,
    b: &Operand,
    f: impl Fn(f64, f64) -> f64,
    why: impl Fn(f64, f64) -> String,
) -> RhaiResult<Field> {
    let n = common_len(op, &[a, b])?.unwrap_or(1);
    Counted::build(n, &label(op), |out| {
        for i in 0..n {
            let (x, y) = (a.at(i), b.at(i));
            let z = f(x, y);
            if !z.is_finite() && x.is_finite() && y.is_finite() {
                return Err(err(format!("{}: element {i} {}", label(op), why(x, y))));
            }
            out.push(z);
        }
        Ok(())
    })
    .map(|c| Field(Rc::new(c)))
}

/// `mask ? a : b` element by element: MatDEM's `a(mask) = …` without a loop.
pub fn choose(mask: &Mask, a: &Operand, b: &Operand) -> RhaiResult<Field> {
    let n = mask.0.len();
    for o in [a, b] {
        if let Some(len) = o.len().filter(|&len| len != n) {
            return Err(err(format!("where: the mask has {n} entries but a field has {len}")));
        }
    }
    Field::collect(n, "where", (0..n).map(|i| if mask.0[i] { a.at(i) } else { b.at(i) }))
}

/// Element-wise smaller (`pick_max` false) or larger of `a` and `b`; NaN stays NaN.
fn extreme(op: &str, a: &Operand, b: &Operand, pick_max: bool) -> RhaiResult<Field> {
    let f = move |x: f64, y: f64| match (x.is_nan() || y.is_nan(), pick_max) {
        (true, _) => f64::NAN,
        (false, true) => x.max(y),
        (false, false) => x.min(y),
    };
    binary(op, a, b, f, |_, _| unreachable_message())
}

/// For operations that cannot turn finite values into non-finite ones.
fn unreachable_message() -> String {
    "became non-finite from finite values (a bug; please report it)".to_string()
}

/// Why `x op y` (finite) is not finite.
fn arithmetic_why(op: &'static str) -> impl Fn(f64, f64) -> String {
    move |x, y| {
        if op == "/" && y == 0.0 {
            format!(
                "divides {} by zero; divide only where the divisor is non-zero \
                 (`let m = b.abs() > 0.0; a.select(m) / b.select(m)`) or bound it (`a / max(b, 1e-12)`)",
                show(x)
            )
        } else {
            format!(
                "overflows: {} {op} {} is beyond ±{LARGEST}; rescale the values first (e.g. to MPa)",
                show(x),
                show(y)
            )
        }
    }
}

/// Why `x^y` (finite) is not finite.
fn pow_why(x: f64, y: f64) -> String {
    if x == 0.0 && y < 0.0 {
        format!("is 0 and 0^{} divides by zero; raise only the non-zero values", show(y))
    } else if x < 0.0 && y.fract() != 0.0 {
        format!(
            "is {} (negative) and the exponent {} is not a whole number: no real result; \
             use `abs(x).pow(e)` or `max(x, 0.0).pow(e)`",
            show(x),
            show(y)
        )
    } else {
        format!("overflows: {}^{} is beyond ±{LARGEST}; rescale the values first", show(x), show(y))
    }
}

/// Why the logarithm `name` of finite `x` is not finite.
fn log_why(name: &'static str) -> impl Fn(f64) -> String {
    move |x| {
        let what =
            if x == 0.0 { "0 (the logarithm of 0 is −∞)".to_string() } else { format!("{} (negative)", show(x)) };
        format!(
            "is {what}; {name} needs x > 0: select the positive values first (`f.select(f > 0.0).{name}()`) \
             or bound them (`max(f, 1e-300).{name}()`)"
        )
    }
}

/// An operation's name for a message: `sqrt` as is, an operator in backquotes (`` `/` ``).
fn label(op: &str) -> String {
    if op.chars().all(|c| c.is_alphanumeric() || c == '_') {
        op.to_string()
    } else {
        format!("`{op}`")
    }
}

/// The largest finite number, for messages.
const LARGEST: &str = "1.8e308";

/// A number for a message: plain where that is short, else in scientific notation.
fn show(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-3..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
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

/// `random_field(n, seed[, distribution[, shape]])`: n values drawn from a seeded generator
/// (SplitMix64, the packings' own), the same on every machine: "uniform" in [0, 1), "normal"
/// (mean 0, standard deviation 1; Box–Muller) or "weibull" with shape m and scale 1 (a rock's
/// homogeneity index in RFPA-style strength fields; divide by its mean for a mean of 1).
fn random_field(n: INT, seed: INT, dist: &str, shape: Option<Dynamic>) -> RhaiResult<Field> {
    let call = format!("random_field({n}, {seed}, \"{dist}\")");
    if !(0..=MAX_FIELD_LEN).contains(&n) {
        return Err(err(format!("{call}: a field holds 0 to {MAX_FIELD_LEN} values")));
    }
    if seed < 0 {
        return Err(err(format!("{call}: the seed must be 0 or more")));
    }
    let mut rng = matdem_engine::builder::Rng::new(seed as u64);
    let n_values = n as usize;
    match (dist, shape) {
        ("uniform", None) => Field::collect(n_values, &call, (0..n).map(|_| rng.uniform())),
        // 1 − u lies in (0, 1]: a logarithm's argument.
        ("normal", None) => Field::collect(
            n_values,
            &call,
            (0..n).map(|_| {
                let (u, v) = (1.0 - rng.uniform(), rng.uniform());
                (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
            }),
        ),
        ("weibull", Some(m)) => {
            let m = number(&m).filter(|m| m.is_finite() && *m > 0.0).ok_or_else(|| {
                err(format!("{call}: the shape m must be a number above 0 (1 spreads strengths widely, 10 hardly)"))
            })?;
            Field::collect(n_values, &call, (0..n).map(|_| (-(1.0 - rng.uniform()).ln()).powf(1.0 / m)))
        }
        ("weibull", None) => Err(err(format!("{call}: give its shape m: random_field(n, seed, \"weibull\", m)"))),
        ("uniform" | "normal", Some(_)) => Err(err(format!("{call}: this distribution takes no shape"))),
        _ => Err(err(format!("{call}: unknown distribution; use \"uniform\", \"normal\" or \"weibull\""))),
    }
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
            Field::collect(n as usize, &format!("zeros({n})"), std::iter::repeat(0.0))
        })
        .register_fn("linspace", |start: Dynamic, end: Dynamic, n: INT| -> RhaiResult<Field> {
            let call = format!("linspace({start}, {end}, {n})");
            let (Some(a), Some(b)) = (number(&start), number(&end)) else {
                return Err(err(format!("{call}: start and end must be numbers")));
            };
            if !(a.is_finite() && b.is_finite()) {
                return Err(err(format!("{call}: start and end must be finite")));
            }
            if !(0..=MAX_FIELD_LEN).contains(&n) {
                return Err(err(format!("{call}: a field holds 0 to {MAX_FIELD_LEN} values")));
            }
            let step = (b - a) / (n - 1).max(1) as f64;
            // The last value is `end` itself, not a sum that rounds near it.
            let value = move |i: INT| if i == n - 1 && n > 1 { b } else { a + step * i as f64 };
            Field::collect(n as usize, &call, (0..n).map(value))
        })
        .register_fn("random_field", |n: INT, seed: INT| random_field(n, seed, "uniform", None))
        .register_fn("random_field", |n: INT, seed: INT, dist: &str| random_field(n, seed, dist, None))
        .register_fn("random_field", |n: INT, seed: INT, dist: &str, shape: Dynamic| {
            random_field(n, seed, dist, Some(shape))
        })
        .register_fn("len", |f: &mut Field| f.0.len() as INT)
        .register_get("len", |f: &mut Field| f.0.len() as INT)
        .register_fn("sum", |f: &mut Field| f.sum())
        .register_fn("mean", |f: &mut Field| f.mean())
        .register_fn("max", |f: &mut Field| f.max())
        .register_fn("min", |f: &mut Field| f.min())
        .register_fn("is_finite", |f: &mut Field| f.is_finite())
        .register_fn("abs", |f: &mut Field| f.unary("abs", f64::abs, |_| unreachable_message()))
        // Binning (per-element material values take at most 256 classes): round to the nearest
        // integer, half away from zero, or down.
        .register_fn("round", |f: &mut Field| f.unary("round", f64::round, |_| unreachable_message()))
        .register_fn("floor", |f: &mut Field| f.unary("floor", f64::floor, |_| unreachable_message()))
        .register_fn("sqrt", |f: &mut Field| {
            f.unary("sqrt", f64::sqrt, |x| {
                format!(
                    "is {} (negative); take the square root of `abs(f)`, or of `max(f, 0.0)` where the negatives are round-off",
                    show(x)
                )
            })
        })
        .register_fn("exp", |f: &mut Field| {
            f.unary("exp", f64::exp, |x| {
                format!("is {}: exp overflows beyond {LARGEST} for x > 709.78; rescale the values first", show(x))
            })
        })
        .register_fn("ln", |f: &mut Field| f.unary("ln", f64::ln, log_why("ln")))
        .register_fn("log10", |f: &mut Field| f.unary("log10", f64::log10, log_why("log10")))
        .register_fn("clamp", |f: &mut Field, lo: Dynamic, hi: Dynamic| -> RhaiResult<Field> {
            let bound = |v: &Dynamic, which: &str| {
                number(v).ok_or_else(|| err(format!("clamp: {which} must be a number, got {}", v.type_name())))
            };
            f.clamp(bound(&lo, "lo")?, bound(&hi, "hi")?)
        })
        .register_fn("where", |m: Mask, a: Dynamic, b: Dynamic| -> RhaiResult<Field> {
            choose(&m, &Operand::from_dynamic(&a, "where")?, &Operand::from_dynamic(&b, "where")?)
        })
        .register_fn("to_array", |f: &mut Field| -> RhaiResult<Array> {
            // A script array takes 16 bytes a value: it must fit beside the fields (it is not
            // counted once made; the array limit bounds it where it is held).
            let _room = Charge::new(16 * f.0.len() as u64, "to_array").map_err(err)?;
            Ok(f.0.iter().map(|v| Dynamic::from_float(*v)).collect::<Array>())
        })
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
    // Operations of two operands, a Field and a Field or number on either side. A number
    // must be finite; a result is refused where finite operands give NaN or ±inf.
    macro_rules! two_operands {
        ($name:literal, |$a:ident, $b:ident| $body:expr) => {
            engine
                .register_fn($name, |a: Field, b: Field| {
                    let ($a, $b) = (Operand::from(a), Operand::from(b));
                    $body
                })
                .register_fn($name, |a: Field, b: FLOAT| {
                    let ($a, $b) = (Operand::from(a), Operand::from_dynamic(&Dynamic::from_float(b), $name)?);
                    $body
                })
                .register_fn($name, |a: FLOAT, b: Field| {
                    let ($a, $b) = (Operand::from_dynamic(&Dynamic::from_float(a), $name)?, Operand::from(b));
                    $body
                })
                .register_fn($name, |a: Field, b: INT| {
                    let ($a, $b) = (Operand::from(a), Operand::from(b as f64));
                    $body
                })
                .register_fn($name, |a: INT, b: Field| {
                    let ($a, $b) = (Operand::from(a as f64), Operand::from(b));
                    $body
                });
        };
    }
    two_operands!("+", |a, b| binary("+", &a, &b, |x, y| x + y, arithmetic_why("+")));
    two_operands!("-", |a, b| binary("-", &a, &b, |x, y| x - y, arithmetic_why("-")));
    two_operands!("*", |a, b| binary("*", &a, &b, |x, y| x * y, arithmetic_why("*")));
    two_operands!("/", |a, b| binary("/", &a, &b, |x, y| x / y, arithmetic_why("/")));
    two_operands!("pow", |a, b| binary("pow", &a, &b, f64::powf, pow_why));
    two_operands!("**", |a, b| binary("**", &a, &b, f64::powf, pow_why));
    two_operands!("min", |a, b| extreme("min", &a, &b, false));
    two_operands!("max", |a, b| extreme("max", &a, &b, true));
    engine.register_fn("-", |a: Field| Field::collect(a.0.len(), "`-`", a.0.iter().map(|x| -x)));
    macro_rules! compare {
        ($op:literal, $f:expr) => {
            engine
                .register_fn($op, |a: Field, b: Field| a.cmp(&b, $op, $f))
                .register_fn($op, |a: Field, b: FLOAT| a.cmp_scalar(b, $op, $f))
                .register_fn($op, |a: Field, b: INT| a.cmp_scalar(b as f64, $op, $f));
        };
    }
    compare!("<", |a: f64, b: f64| a < b);
    compare!("<=", |a: f64, b: f64| a <= b);
    compare!(">", |a: f64, b: f64| a > b);
    compare!(">=", |a: f64, b: f64| a >= b);
    engine
        .register_fn("&", |a: Mask, b: Mask| mask_zip(&a, &b, |x, y| x && y))
        .register_fn("|", |a: Mask, b: Mask| mask_zip(&a, &b, |x, y| x || y))
        .register_fn("!", |a: Mask| Mask::collect(a.0.len(), "`!`", a.0.iter().map(|x| !x)))
        .register_fn("count", |m: &mut Mask| m.0.iter().filter(|x| **x).count() as INT)
        .register_fn("len", |m: &mut Mask| m.0.len() as INT)
        .register_fn("ids", |m: &mut Mask| -> RhaiResult<Array> {
            let n = m.0.iter().filter(|x| **x).count();
            let _room = Charge::new(16 * n as u64, "ids").map_err(err)?;
            Ok(m.0.iter().enumerate().filter(|(_, x)| **x).map(|(i, _)| Dynamic::from_int(i as INT)).collect::<Array>())
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
    Mask::collect(a.0.len(), "combine masks", a.0.iter().zip(b.0.iter()).map(|(x, y)| f(*x, *y)))
}

fn summary(v: &[f64]) -> String {
    let head: Vec<String> = v.iter().take(6).map(|x| format!("{x:.6e}")).collect();
    let more = if v.len() > 6 { ", …" } else { "" };
    format!("Field[{}]({}{more})", v.len(), head.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(v: &[f64]) -> Field {
        Field::new(v.to_vec())
    }

    fn message(r: RhaiResult<impl std::fmt::Debug>) -> String {
        r.expect_err("expected a refusal").to_string()
    }

    #[test]
    fn a_division_that_makes_nan_from_zero_over_zero_is_refused_naming_the_element() {
        let e = message(binary("/", &f(&[1.0, 0.0]).into(), &f(&[2.0, 0.0]).into(), |x, y| x / y, arithmetic_why("/")));
        assert!(e.contains("`/`: element 1 divides 0 by zero"), "{e}");
    }

    #[test]
    fn nan_already_in_a_field_passes_through_element_wise_maths() {
        let out =
            binary("*", &f(&[f64::NAN, 2.0]).into(), &Operand::Number(3.0), |x, y| x * y, arithmetic_why("*")).unwrap();
        assert!(out.0[0].is_nan());
        assert_eq!(out.0[1], 6.0);
        let out = f(&[f64::NAN, 4.0]).unary("sqrt", f64::sqrt, |_| unreachable_message()).unwrap();
        assert!(out.0[0].is_nan() && out.0[1] == 2.0);
    }

    #[test]
    fn element_wise_min_and_max_keep_nan_as_a_missing_value() {
        let out = extreme("min", &f(&[f64::NAN, 5.0]).into(), &Operand::Number(1.0), false).unwrap();
        assert!(out.0[0].is_nan());
        assert_eq!(out.0[1], 1.0);
    }

    #[test]
    fn clamp_with_a_nan_bound_or_lo_above_hi_is_an_error_not_a_panic() {
        for (lo, hi) in [(f64::NAN, 1.0), (0.0, f64::NAN), (2.0, 1.0), (f64::NEG_INFINITY, 0.0)] {
            assert!(message(f(&[1.0]).clamp(lo, hi)).contains("clamp: the bounds"));
        }
        assert_eq!(f(&[-1.0, 0.5, 9.0]).clamp(0.0, 1.0).unwrap().0.as_slice(), [0.0, 0.5, 1.0]);
    }

    #[test]
    fn the_mean_of_values_near_the_largest_number_does_not_overflow() {
        assert_eq!(f(&[f64::MAX, f64::MAX]).mean().unwrap(), f64::MAX);
        assert!(message(f(&[f64::MAX, f64::MAX]).sum()).contains("overflows"));
    }

    #[test]
    fn where_refuses_a_field_of_another_length_than_the_mask() {
        let mask = Mask::new(vec![true, false]);
        let e = message(choose(&mask, &f(&[1.0, 2.0, 3.0]).into(), &Operand::Number(0.0)));
        assert!(e.contains("the mask has 2 entries but a field has 3"), "{e}");
    }

    #[test]
    fn messages_show_numbers_short() {
        assert_eq!(show(-3.2e-4), "-3.2e-4");
        assert_eq!(show(0.0), "0");
        assert_eq!(show(2.5), "2.5");
        assert_eq!(show(f64::NAN), "NaN");
    }
}
