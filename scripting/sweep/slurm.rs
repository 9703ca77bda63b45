//! `sweep slurm DIR`: a Slurm job array with one array task per pending point, each running
//! `matdem-rs sweep point DIR INDEX`. The binary, the source and the sweep folder are reached
//! by absolute path, so they must be on a file system the compute nodes share (as a home or
//! project folder on a cluster is). Tasks write only into the sweep folder; `sweep status`
//! and `sweep collect` read it, never Slurm's database.

use super::plan::{absolute, SweepPlan};
use super::point::is_pending;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The job script's file name in the sweep folder.
pub const SCRIPT_FILE: &str = "sweep.sbatch";
/// Where the array tasks' own stdout and stderr go (the runs' logs are in their folders).
pub const LOG_DIR: &str = "slurm";

/// `#SBATCH` choices; `None` leaves Slurm's (or the cluster's) default.
#[derive(Debug, Clone, Default)]
pub struct SlurmOptions {
    pub partition: Option<String>,
    /// Per array task, as Slurm reads it (`30`, `2:00:00`, `1-00:00:00`).
    pub time: Option<String>,
    pub cpus_per_task: Option<u32>,
    /// Per array task (`4G`).
    pub mem: Option<String>,
    pub account: Option<String>,
    /// At most this many tasks at once (`--array=…%N`).
    pub max_parallel: Option<u32>,
    pub retry_failed: bool,
}

/// Writes `DIR/sweep.sbatch` for the pending points and returns its path and the number of
/// array tasks; `Ok(None)` when every point is finished.
pub fn write_script(
    dir: &Path,
    plan: &SweepPlan,
    exe: &Path,
    opts: &SlurmOptions,
) -> Result<Option<(PathBuf, usize)>, String> {
    super::point::check_source(plan)?;
    let mut pending = Vec::new();
    for (k, p) in plan.points.iter().enumerate() {
        if is_pending(dir, &p.name, opts.retry_failed)? {
            pending.push(k);
        }
    }
    if pending.is_empty() {
        return Ok(None);
    }
    let dir = absolute(dir);
    let exe = absolute(exe);
    // `#SBATCH` lines are not a shell: a path there cannot be quoted, so it must not need it.
    for (what, p) in [("sweep folder", &dir), ("matdem-rs binary", &exe)] {
        let text = p.to_string_lossy();
        if text.chars().any(|c| c.is_whitespace() || c.is_control() || matches!(c, '%' | '"' | '\'' | '\\' | '$')) {
            return Err(format!(
                "the {what} {} has a space, quote, `%`, `$` or `\\` in its path, which an #SBATCH line cannot hold; \
                 move it to a plain path",
                p.display()
            ));
        }
    }
    if opts.cpus_per_task == Some(0) {
        return Err("--cpus-per-task 0 gives each point no CPU; give at least 1".into());
    }
    if let Some(t) = &opts.time {
        check_time(t)?;
    }
    let mut array = ranges(&pending);
    if let Some(n) = opts.max_parallel {
        if n == 0 {
            return Err("--max-parallel 0 would run nothing; give at least 1".into());
        }
        let _ = write!(array, "%{n}");
    }
    let name = plan.source.file_stem().map_or("sweep".into(), |s| s.to_string_lossy().into_owned());
    let name: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    let mut s = String::from("#!/bin/bash\n");
    let _ = writeln!(s, "# A matdem-rs sweep as a Slurm job array: one array task per point.");
    let _ = writeln!(s, "# Written by `matdem-rs sweep slurm`; submit with `sbatch {SCRIPT_FILE}`.");
    let _ = writeln!(s, "#SBATCH --job-name=matdem-{name}");
    let _ = writeln!(s, "#SBATCH --array={array}");
    let _ = writeln!(s, "#SBATCH --output={}/{LOG_DIR}/%A_%a.out", dir.display());
    let _ = writeln!(s, "#SBATCH --chdir={}", dir.display());
    for (flag, value) in [
        ("partition", opts.partition.clone()),
        ("time", opts.time.clone()),
        ("cpus-per-task", opts.cpus_per_task.map(|n| n.to_string())),
        ("mem", opts.mem.clone()),
        ("account", opts.account.clone()),
    ] {
        if let Some(v) = value {
            check_word(flag, &v)?;
            let _ = writeln!(s, "#SBATCH --{flag}={v}");
        }
    }
    let _ = writeln!(s, "set -eu");
    let _ = writeln!(s, "# The run's threads: the CPUs Slurm gave this task.");
    let _ = writeln!(s, "export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\"");
    let _ = writeln!(s, "exec {} sweep point {} \"$SLURM_ARRAY_TASK_ID\"", quote(&exe), quote(&dir));
    let logs = dir.join(LOG_DIR);
    std::fs::create_dir_all(&logs).map_err(|e| format!("cannot create {}: {e}", logs.display()))?;
    let path = dir.join(SCRIPT_FILE);
    crate::atomic_write::write(&path, s.as_bytes()).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(Some((path, pending.len())))
}

/// Submits the job script with `sbatch` and returns the job id.
pub fn submit(script: &Path) -> Result<String, String> {
    let dir = script.parent().unwrap_or(Path::new("."));
    let out =
        std::process::Command::new("sbatch").arg("--parsable").arg(script).current_dir(dir).output().map_err(|e| {
            format!("cannot run sbatch ({e}); is Slurm installed here? Submit {} on a login node", script.display())
        })?;
    if !out.status.success() {
        return Err(format!("sbatch refused {}: {}", script.display(), String::from_utf8_lossy(&out.stderr).trim()));
    }
    // `--parsable` prints `JOBID` or `JOBID;CLUSTER`.
    let text = String::from_utf8_lossy(&out.stdout);
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(format!("sbatch gave no job id (it printed `{}`)", text.trim()));
    }
    Ok(id)
}

/// `0-3,5,7-9`: Slurm's array index list for `indices` (sorted, distinct).
pub fn ranges(indices: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut k = 0;
    while k < indices.len() {
        let start = indices[k];
        let mut end = start;
        while k + 1 < indices.len() && indices[k + 1] == end + 1 {
            k += 1;
            end += 1;
        }
        parts.push(if start == end { start.to_string() } else { format!("{start}-{end}") });
        k += 1;
    }
    parts.join(",")
}

/// An option value that goes on an `#SBATCH` line as one word.
fn check_word(flag: &str, v: &str) -> Result<(), String> {
    let ok =
        !v.is_empty() && v.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | ':' | '.' | ',' | '+'));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "--{flag} `{}`: give one word of letters, digits and `_-:.,+` (e.g. --time 2:00:00)",
            v.escape_debug()
        ))
    }
}

/// Slurm's time formats: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`, or `UNLIMITED`.
/// Refused here, a typo is not first found by sbatch after the array was written.
fn check_time(t: &str) -> Result<(), String> {
    let numbers = |s: &str, most: usize| {
        let parts: Vec<&str> = s.split(':').collect();
        parts.len() <= most
            && parts.iter().all(|p| !p.is_empty() && p.len() <= 6 && p.bytes().all(|b| b.is_ascii_digit()))
    };
    let ok = matches!(t, "UNLIMITED" | "INFINITE")
        || match t.split_once('-') {
            Some((days, rest)) => numbers(days, 1) && numbers(rest, 3),
            None => numbers(t, 3),
        };
    if ok {
        Ok(())
    } else {
        Err(format!(
            "--time `{}` is not a Slurm time: give minutes (`90`), `H:M:S` (`2:00:00`) or `D-H:M:S` (`1-12:00:00`)",
            t.escape_debug()
        ))
    }
}

/// `path` in single quotes for the shell.
fn quote(path: &Path) -> String {
    format!("'{}'", path.to_string_lossy().replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn array_indices_collapse_into_ranges() {
        assert_eq!(ranges(&[0, 1, 2, 3]), "0-3");
        assert_eq!(ranges(&[0, 2, 3, 4, 7, 9, 10]), "0,2-4,7,9-10");
        assert_eq!(ranges(&[5]), "5");
    }

    #[test]
    fn an_option_that_would_add_an_sbatch_line_is_refused() {
        assert!(check_word("time", "2:00:00").is_ok());
        for good in ["90", "2:00:00", "1-12", "1-12:00:00", "30:00", "UNLIMITED"] {
            assert!(check_time(good).is_ok(), "{good}");
        }
        for bad in ["abc", "", "1:2:3:4", "-5", "1-", "2h"] {
            assert!(check_time(bad).unwrap_err().contains("is not a Slurm time"), "{bad}");
        }
        assert!(check_word("partition", "gpu\n#SBATCH --uid=0").is_err());
        assert!(check_word("partition", "a b").is_err());
    }
}
