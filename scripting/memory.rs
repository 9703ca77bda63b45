//! The run's memory budget for what a script can make in bulk with one call: fields and
//! masks (whole arrays), tables and charts. Each holds a [`Charge`] for its bytes; the bytes
//! of every live charge are one process-wide count, compared with `--max-memory`.
//!
//! Two checks keep the count under the limit: a call that would allocate in bulk asks
//! [`Charge::new`] first (and allocates with `try_reserve`, so even an allocation the system
//! refuses is an error, not an abort), and the script's progress callback stops the script
//! at its next operation once values counted after the fact ([`Charge::counted`]: a table's
//! rows, a copy of a model's lane) have taken the count over the limit.
//!
//! One process runs one script, so the count and the limit are globals; they are
//! bookkeeping, not physics.

use rhai::Dynamic;
use std::sync::atomic::{AtomicU64, Ordering};

static LIVE: AtomicU64 = AtomicU64::new(0);
static LIMIT: AtomicU64 = AtomicU64::new(u64::MAX);

/// The share of the machine's memory a run's bulk values may take by default: the model,
/// the script's own values and the other programs on the machine need the rest.
const DEFAULT_SHARE: u64 = 2;

/// Sets the limit (bytes) for this process.
pub fn set_limit(bytes: u64) {
    LIMIT.store(bytes, Ordering::Relaxed);
}

/// The bytes the live fields, masks, tables and charts hold.
pub fn live() -> u64 {
    LIVE.load(Ordering::Relaxed)
}

/// The default `--max-memory`: half of the smallest of this machine's physical memory, the
/// control group's limit and the address-space limit (`ulimit -v`), or 4 GiB where none is
/// known.
pub fn default_limit() -> u64 {
    machine_memory().map_or(4 << 30, |m| m / DEFAULT_SHARE)
}

/// The memory this process can have: physical memory, capped by a cgroup v2 limit and by
/// `RLIMIT_AS`.
fn machine_memory() -> Option<u64> {
    // SAFETY: sysconf and getrlimit only read system values into locals.
    let physical = unsafe {
        let pages = libc::sysconf(libc::_SC_PHYS_PAGES);
        let size = libc::sysconf(libc::_SC_PAGESIZE);
        (pages > 0 && size > 0).then(|| pages as u64 * size as u64)
    };
    let cgroup = std::fs::read_to_string("/sys/fs/cgroup/memory.max").ok().and_then(|t| t.trim().parse::<u64>().ok());
    let address_space = unsafe {
        let mut r = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
        (libc::getrlimit(libc::RLIMIT_AS, &mut r) == 0 && r.rlim_cur != libc::RLIM_INFINITY).then_some(r.rlim_cur)
    };
    [physical, cgroup, address_space].into_iter().flatten().min()
}

/// Bytes for people: `512 B`, `8.0 MiB`, `11.6 GiB`.
pub fn show(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut v = bytes as f64 / 1024.0;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    format!("{v:.1} {}", UNITS[unit])
}

/// A size as typed for `--max-memory`: a whole number of bytes, or with K, M, G or T
/// (powers of 1024; `16G`, `512M`, `2GiB`). Zero is refused: it would refuse every field.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let digits = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (number, unit) = t.split_at(digits);
    let scale: u64 = match unit.trim().to_ascii_uppercase().trim_end_matches("IB").trim_end_matches('B') {
        "" => 1,
        "K" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        "T" => 1 << 40,
        _ => return Err(format!("`{text}` is not a size; give bytes or a number with K, M, G or T (e.g. 16G)")),
    };
    let n: u64 = number.parse().map_err(|_| format!("`{text}` is not a size; give e.g. 512M or 16G"))?;
    match n.checked_mul(scale) {
        Some(0) => Err("0 would refuse every field; give at least 1 (or leave the option out for the default)".into()),
        Some(b) => Ok(b),
        None => Err(format!("`{text}` is larger than this machine can address")),
    }
}

/// Why `what` is refused: `more` bytes on top of what is live would pass the limit.
fn refusal(what: &str, more: u64, limit: u64) -> String {
    format!(
        "{what}: {} more would bring the fields, masks, tables and charts this run holds to {}, over the \
         --max-memory limit of {}; let go of the arrays no longer needed (a field lives while a variable or an \
         array holds it), work on a selection, or raise the limit with --max-memory SIZE (e.g. --max-memory 32G)",
        show(more),
        show(live().saturating_add(more)),
        show(limit)
    )
}

/// Bytes counted in the budget while this value lives.
#[derive(Debug, Default)]
pub struct Charge(u64);

impl Charge {
    /// Counts `bytes` for `what` if they fit under the limit, else refuses naming the limit.
    pub fn new(bytes: u64, what: &str) -> Result<Charge, String> {
        let limit = LIMIT.load(Ordering::Relaxed);
        let before = LIVE.fetch_add(bytes, Ordering::Relaxed);
        if before.saturating_add(bytes) > limit {
            LIVE.fetch_sub(bytes, Ordering::Relaxed);
            return Err(refusal(what, bytes, limit));
        }
        Ok(Charge(bytes))
    }

    /// Counts `bytes` already allocated, whatever the limit: the script stops at its next
    /// operation if they took the count over it (see [`over_limit`]).
    pub fn counted(bytes: u64) -> Charge {
        LIVE.fetch_add(bytes, Ordering::Relaxed);
        Charge(bytes)
    }

    /// Counts `bytes` more, already allocated (see [`Charge::counted`]).
    pub fn add(&mut self, bytes: u64) {
        LIVE.fetch_add(bytes, Ordering::Relaxed);
        self.0 += bytes;
    }
}

impl Drop for Charge {
    fn drop(&mut self) {
        LIVE.fetch_sub(self.0, Ordering::Relaxed);
    }
}

/// An empty vector with room for `n` items, its bytes counted for `what`: refused when they
/// would pass the limit or the system cannot give them (never an abort).
pub fn vec_for<T>(n: usize, what: &str) -> Result<(Vec<T>, Charge), String> {
    let bytes = (n as u64).saturating_mul(std::mem::size_of::<T>() as u64);
    let charge = Charge::new(bytes, what)?;
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        format!("{what}: the system cannot give {} more memory; work on a selection, or free memory", show(bytes))
    })?;
    Ok((v, charge))
}

/// Why the script was stopped: the values counted after the fact took the count over the
/// limit. It travels as the progress callback's termination token (a type scripts cannot
/// make, so no script can forge or catch it).
#[derive(Debug, Clone, Copy)]
pub struct OverLimit {
    pub live: u64,
    pub limit: u64,
}

impl OverLimit {
    pub fn message(&self) -> String {
        format!(
            "the fields, masks, tables and charts this run holds take {}, over the --max-memory limit of {}; let go \
             of the arrays no longer needed (a field lives while a variable or an array holds it), or raise the \
             limit with --max-memory SIZE (e.g. --max-memory 32G)",
            show(self.live),
            show(self.limit)
        )
    }
}

/// The termination token for a progress callback when the count is over the limit.
pub fn over_limit() -> Option<Dynamic> {
    let (live, limit) = (live(), LIMIT.load(Ordering::Relaxed));
    (live > limit).then(|| Dynamic::from(OverLimit { live, limit }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_read_with_binary_units_and_zero_or_junk_is_refused() {
        assert_eq!(parse_size("16G").unwrap(), 16 << 30);
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("2GiB").unwrap(), 2 << 30);
        assert_eq!(parse_size("1000").unwrap(), 1000);
        assert!(parse_size("0").unwrap_err().contains("0 would refuse"));
        assert!(parse_size("lots").is_err());
        assert!(parse_size("99999999999T").is_err());
        assert_eq!(show(8 << 20), "8.0 MiB");
    }

    #[test]
    fn the_default_is_half_of_what_this_machine_has() {
        let m = machine_memory().expect("Linux reports its memory");
        assert_eq!(default_limit(), m / 2);
    }
}
