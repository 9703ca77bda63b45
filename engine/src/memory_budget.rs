//! Whether a scene fits in this machine's memory, asked before allocating it: a model that
//! would exhaust memory is refused with the figure and what the machine has, instead of
//! being killed (or aborting) half-way through.

use crate::error::{Error, Result};

/// Bytes one particle costs on the CPU backend with its contact rows, as a planning figure
/// (lanes, about 12 contact-row entries with their carried shear and ledgers, cell lists).
pub const CPU_BYTES_PER_PARTICLE: u64 = 1_000;

/// The share of the available memory a model may plan to take; the rest is for the host,
/// outputs and the other programs on the machine.
const USABLE_SHARE: f64 = 0.8;

/// Memory the operating system can give without swapping (`MemAvailable`), if known.
pub fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses `particles` at `bytes_per_particle` when that is more than this machine can
/// hold; `what` names the scene for the message.
pub fn check_fits(what: &str, particles: u64, bytes_per_particle: u64) -> Result<()> {
    check_fits_in(what, particles, bytes_per_particle, available_bytes())
}

fn check_fits_in(what: &str, particles: u64, bytes_per_particle: u64, available: Option<u64>) -> Result<()> {
    let Some(available) = available else { return Ok(()) };
    let need = particles.saturating_mul(bytes_per_particle);
    if (need as f64) <= USABLE_SHARE * available as f64 {
        return Ok(());
    }
    let gb = |b: u64| b as f64 / 1e9;
    Err(Error::InvalidScene(format!(
        "{what}: {particles} particles need about {:.1} GB ({bytes_per_particle} B each), more than {:.0} % of the \
         {:.1} GB this machine has available; use fewer particles (larger grains or a smaller sample) or a \
         machine with more memory",
        gb(need),
        USABLE_SHARE * 100.0,
        gb(available)
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scene_over_the_usable_memory_is_refused_with_both_figures() {
        let gb = 1_000_000_000;
        assert!(check_fits_in("box", 1_000_000, CPU_BYTES_PER_PARTICLE, Some(24 * gb)).is_ok());
        let e = check_fits_in("box", 19_000_000, CPU_BYTES_PER_PARTICLE, Some(23 * gb)).unwrap_err().to_string();
        assert!(e.contains("19000000 particles need about 19.0 GB") && e.contains("23.0 GB"), "{e}");
        // Unknown memory (no /proc): nothing to compare with, nothing refused.
        assert!(check_fits_in("box", u64::MAX, u64::MAX, None).is_ok());
    }

    #[test]
    fn this_machine_reports_its_available_memory() {
        let bytes = available_bytes().expect("Linux has /proc/meminfo");
        assert!(bytes > 1 << 20, "{bytes}");
    }
}
