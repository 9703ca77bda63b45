//! A run folder's page: what ran, how it ended, the plan, what it reported and wrote.

use super::html::{csv_table, escape, fields, output_sections, page, Outputs};
use crate::metrics::METRICS_FILE;
use crate::run_record::RunRecord;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What the host knows of a run besides its files.
pub struct RunSummary<'a> {
    pub record: &'a RunRecord,
    /// Each model's plan as `d.plan()` prints it, by model name, as of its first run.
    pub plans: Vec<(String, String)>,
    pub wall_s: f64,
    /// How a run that did not finish ended (the error as the terminal showed it).
    pub error: Option<String>,
}

/// Writes `out_dir/index.html` for a run (atomically) and returns its path.
pub fn write_run_page(out_dir: &Path, run: &RunSummary) -> std::io::Result<PathBuf> {
    let r = run.record;
    let title = format!("{} — {}", r.script, r.status);
    let mut body = String::new();
    let _ = writeln!(
        body,
        "<h1>{} <span class=\"{}\">{}</span></h1>",
        escape(&r.script),
        escape(&r.status),
        escape(&r.status)
    );
    if let Some(e) = &run.error {
        let _ = writeln!(body, "<pre class=\"failed\">{}</pre>", escape(e));
    }
    body.push_str("<h2>Run</h2>\n");
    let params = r.parameters.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(" ");
    body.push_str(&fields(&[
        ("script", r.script.clone()),
        ("SHA-256", r.script_sha256.clone()),
        ("parameters", if params.is_empty() { "(defaults)".into() } else { params }),
        ("backend", r.backend.clone()),
        ("speed test", r.speed_test.clone().unwrap_or_else(|| "-".into())),
        ("matdem-rs", r.matdem_rs_version.clone()),
        ("started", r.started.clone()),
        ("finished", r.finished.clone().unwrap_or_default()),
        ("wall time", format!("{:.1} s", run.wall_s)),
        ("exit code", r.exit_code.map(|c| c.to_string()).unwrap_or_default()),
        ("resumed from", r.resumed_from.clone().unwrap_or_else(|| "-".into())),
    ]));
    for (name, plan) in &run.plans {
        let _ = writeln!(body, "<h2>Plan of <code>{}</code></h2>\n<pre>{}</pre>", escape(name), escape(plan));
    }
    if let Ok(text) = std::fs::read_to_string(out_dir.join(METRICS_FILE)) {
        body.push_str("<h2>Reported</h2>\n");
        body.push_str(&csv_table(&text, 100));
    }
    body.push_str(&output_sections(&Outputs::of(out_dir), &[METRICS_FILE]));
    let path = out_dir.join(super::PAGE_FILE);
    crate::atomic_write::write(&path, page(&title, &body).as_bytes())?;
    Ok(path)
}
