//! The run record: `run.ron` in every run folder says what ran — the script and its SHA-256,
//! the parameters, the backend, the matdem-rs version, when it started and ended, and how it
//! ended — so a result can be traced back to exactly what produced it.

use serde::Serialize;
use sha2::{Digest, Sha256};
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

/// The file name in the run folder.
pub const RUN_RECORD: &str = "run.ron";

#[derive(Debug, Clone, Serialize)]
pub struct RunRecord {
    pub script: String,
    pub script_sha256: String,
    /// `--set` parameters as given.
    pub parameters: Vec<(String, String)>,
    pub backend: String,
    /// `--backend auto`'s speed test: both figures and the choice (absent when it did not measure).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_test: Option<String>,
    pub matdem_rs_version: String,
    /// UTC, RFC 3339.
    pub started: String,
    pub finished: Option<String>,
    /// `running`, `ok`, `failed`, `interrupted` (resumable) or `could not start`.
    pub status: String,
    pub exit_code: Option<u8>,
    /// The resume folder this run continued from, if it is a resumed run.
    pub resumed_from: Option<String>,
    /// SHA-256 of `resume/journal.ron` when the run was interrupted: a resume refuses a journal
    /// that is not this one (and the journal holds its models' digests).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resume_journal_sha256: Option<String>,
}

impl RunRecord {
    pub fn write(&self, out_dir: &Path) -> std::io::Result<()> {
        let text = ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default())
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        crate::atomic_write::write(&out_dir.join(RUN_RECORD), text.as_bytes())
    }
}

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// Now as UTC RFC 3339, to the second.
pub fn now_utc() -> String {
    let secs = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    utc_string(secs)
}

/// Seconds since 1970 as `YYYY-MM-DDThh:mm:ssZ` (proleptic Gregorian calendar).
pub fn utc_string(secs: u64) -> String {
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// Year, month, day of a day count since 1970-01-01, counting in 400-year eras of 146,097
/// days that start on 1 March, so the leap day falls at the end of each era-year.
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468; // days from 0000-03-01 to 1970-01-01
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097); // day of era, [0, 146096]
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365; // year of era, [0, 399]
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100); // day of the March-based year
    let mp = (5 * doy + 2) / 153; // March = 0
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_strings_match_known_dates() {
        assert_eq!(utc_string(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_string(951_782_400), "2000-02-29T00:00:00Z"); // a 400-year leap day
        assert_eq!(utc_string(1_709_251_199), "2024-02-29T23:59:59Z");
        assert_eq!(utc_string(4_107_542_400), "2100-03-01T00:00:00Z"); // 2100 is not leap
    }

    #[test]
    fn sha256_matches_the_standard_test_vector() {
        assert_eq!(sha256_hex(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    }
}
