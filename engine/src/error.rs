//! Errors the engine reports. User mistakes, numerical instability and cancellation are
//! kept apart so the host can word each one and choose an exit code.

/// Everything the engine can refuse or stop with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("invalid parameter `{name}` = {}: {reason}", Readable(*value))]
    InvalidParameter { name: &'static str, value: f64, reason: String },
    #[error("material `{material}`: {reason}")]
    InvalidMaterial { material: String, reason: String },
    #[error("unknown {kind} `{name}`{}", hint(.suggestion, .known))]
    Unknown { kind: &'static str, name: String, suggestion: Option<String>, known: Vec<String> },
    #[error("particle id {id} is out of range (the model has {count} particles; ids are 0-based)")]
    BadParticleId { id: usize, count: usize },
    #[error("{0}")]
    InvalidScene(String),
    /// The stability guard stopped the run before it produced NaNs.
    #[error("{0}")]
    Unstable(Box<Instability>),
    #[error("run cancelled after {completed_steps} step(s)")]
    Cancelled { completed_steps: u64 },
    /// A host observer (snapshots, movie frames) failed; the message is the host's.
    #[error("{0}")]
    Observer(String),
    /// The GPU backend could not start or run (an environment problem, not the script's).
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// Why the GPU backend cannot run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    #[error("no usable GPU: {reason}; run with --backend cpu (or auto, which falls back to the CPU)")]
    NoAdapter { reason: String },
    #[error(
        "the GPU backend needs {bytes} bytes for its `{lane}` buffer but this device allows {limit} per storage \
         binding; run fewer particles or use --backend cpu"
    )]
    BufferTooLarge { lane: &'static str, bytes: u64, limit: u64 },
    #[error("this build has no GPU backend (compiled without the `gpu` feature); use --backend cpu")]
    NotBuilt,
    #[error("the GPU device failed: {0}")]
    Device(String),
    /// A kernel bound a lane its shader does not declare, or without its buffer.
    #[error("binding a GPU kernel: {0}; this is a bug in matdem-rs, please report it")]
    Binding(String),
}

fn hint(suggestion: &Option<String>, known: &[String]) -> String {
    match suggestion {
        Some(s) => format!(" (did you mean `{s}`?)"),
        None if !known.is_empty() => format!("; known: {}", known.join(", ")),
        None => String::new(),
    }
}

/// What the stability guard found: enough to name the particle, the step and the fix.
#[derive(Debug, Clone, PartialEq)]
pub struct Instability {
    pub step: u64,
    pub particle: usize,
    pub what: String,
    pub dt: f64,
    pub critical_dt: f64,
    pub standard_dt: f64,
    /// The fix, when the check that stopped the run knows it better than the general one.
    pub fix: Option<String>,
    /// The fix's numbers, for a host that knows what its user may set (a packaged simulator's
    /// parameter ranges) and can check them without reading the message: each a quantity of
    /// the scene, by the name scripts set it under, and the side of a bound the run needs it
    /// on. Empty when the fix has no number.
    pub suggest: Vec<Suggestion>,
}

/// One number of a fix: set `parameter` below or above `bound`.
#[derive(Debug, Clone, PartialEq)]
pub struct Suggestion {
    /// The quantity as scripts name it: the fluid's `bulk_modulus`, `viscosity`, `nusselt`,
    /// `max_substeps` (`d.fluid = #{ … }`), or the time step `dt` (s).
    pub parameter: &'static str,
    /// Where the fix begins: the run needs the quantity strictly beyond it.
    pub bound: f64,
    /// Which side of `bound` the fix lies on.
    pub side: Side,
    /// The quantity's unit, for messages ("" for a count or a ratio).
    pub unit: &'static str,
}

/// Below or above a bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    Below,
    Above,
}

impl Suggestion {
    pub fn below(parameter: &'static str, bound: f64, unit: &'static str) -> Self {
        Suggestion { parameter, bound, side: Side::Below, unit }
    }

    pub fn above(parameter: &'static str, bound: f64, unit: &'static str) -> Self {
        Suggestion { parameter, bound, side: Side::Above, unit }
    }
}

impl std::fmt::Display for Instability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "unstable at step {}: particle {} {}; time step dt = {:.3e} s, critical time step {:.3e} s \
             (standard {:.3e} s). ",
            self.step, self.particle, self.what, self.dt, self.critical_dt, self.standard_dt
        )?;
        if let Some(fix) = &self.fix {
            f.write_str(fix)
        } else if self.dt > self.critical_dt || !self.critical_dt.is_finite() {
            write!(
                f,
                "Fix: use the standard time step (set_standard_dt) or a dt below {:.3e} s, or soften the stiffest \
                 material",
                self.critical_dt
            )
        } else {
            // The critical step comes from each element's own stiffness; loaded Hertz contacts
            // and many contacts at once are stiffer, so a dt under it can still be too large.
            write!(
                f,
                "Fix: dt is under the single-element estimate, but loaded contacts are stiffer: use the standard \
                 time step (set_standard_dt) or halve dt (to {:.3e} s), or soften the stiffest material",
                self.dt / 2.0
            )
        }
    }
}

impl Error {
    pub(crate) fn param(name: &'static str, value: f64, reason: impl Into<String>) -> Self {
        Error::InvalidParameter { name, value, reason: reason.into() }
    }

    /// An `Unknown` error with the closest known name as a suggestion.
    pub fn unknown(kind: &'static str, name: &str, known: &[&str]) -> Self {
        let suggestion = known
            .iter()
            .map(|k| (edit_distance(name, k), *k))
            .filter(|(d, k)| *d <= 2.max(k.len() / 3))
            .min()
            .map(|(_, k)| k.to_string());
        Error::Unknown {
            kind,
            name: name.to_string(),
            suggestion,
            known: known.iter().map(|s| s.to_string()).collect(),
        }
    }
}

/// Checks that `value` is finite and positive (or zero when `allow_zero`).
pub(crate) fn check_positive(name: &'static str, value: f64, allow_zero: bool) -> Result<f64, Error> {
    if !value.is_finite() {
        return Err(Error::param(name, value, "must be a finite number"));
    }
    if value < 0.0 || (!allow_zero && value == 0.0) {
        let what = if allow_zero { "must be ≥ 0" } else { "must be > 0" };
        return Err(Error::param(name, value, what));
    }
    Ok(value)
}

/// `` (did you mean `k`?)`` for the known name `k` closest to `name`, or nothing when none
/// is within three edits.
pub fn did_you_mean(name: &str, known: &[&str]) -> String {
    known
        .iter()
        .map(|k| (edit_distance(name, k), *k))
        .min()
        .filter(|(d, _)| *d <= 3)
        .map(|(_, k)| format!(" (did you mean `{k}`?)"))
        .unwrap_or_default()
}

/// Levenshtein distance, for "did you mean" hints.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A value as a person reads it: plain when it is, in exponent form when plain would run to
/// hundreds of digits (1e-300, 1e300).
struct Readable(f64);

impl std::fmt::Display for Readable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a != 0.0 && a.is_finite() && !(1e-4..1e9).contains(&a) {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn instability(dt: f64) -> Instability {
        Instability {
            step: 7,
            particle: 3,
            what: "overlaps".into(),
            dt,
            critical_dt: 1e-6,
            standard_dt: 1e-7,
            fix: None,
            suggest: Vec::new(),
        }
    }

    #[test]
    fn instability_above_the_critical_step_asks_for_a_dt_below_it() {
        let s = instability(2e-6).to_string();
        assert!(s.contains("Fix: use the standard time step (set_standard_dt) or a dt below 1.000e-6 s"), "{s}");
    }

    #[test]
    fn instability_under_the_critical_step_asks_to_halve_dt() {
        let s = instability(4e-7).to_string();
        assert!(s.contains("loaded contacts are stiffer"), "{s}");
        assert!(s.contains("halve dt (to 2.000e-7 s)"), "{s}");
    }
}
