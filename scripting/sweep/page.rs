//! A sweep's (or study's) report page ([`crate::report_page`]): where every point stands, its
//! parameters and metrics, with a link to each point's own page, and the sweep's charts and
//! tables.

use super::collect::{PointResult, PointState};
use super::plan::SweepPlan;
use crate::report_page::html::{escape, href, output_sections, page, Outputs};
use crate::report_page::PAGE_FILE;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Writes `dir/index.html` for a sweep (atomically) and returns its path.
pub fn write_sweep_page(dir: &Path, plan: &SweepPlan, results: &[PointResult]) -> std::io::Result<PathBuf> {
    let source = plan.source.display().to_string();
    let mut body = String::new();
    let _ = writeln!(body, "<h1>Sweep of {}</h1>", escape(&source));
    let count = |s: &str| results.iter().filter(|r| r.state.label() == s).count();
    let _ = writeln!(
        body,
        "<p>{} point(s): {} ok, {} failed, {} running, {} interrupted, {} pending.</p>",
        results.len(),
        count("ok"),
        count("failed"),
        count("running"),
        count("interrupted"),
        count("pending")
    );
    let mut params: Vec<&str> = Vec::new();
    let mut metrics: Vec<&str> = Vec::new();
    for r in results {
        for (n, _) in &r.parameters {
            if !params.contains(&n.as_str()) {
                params.push(n);
            }
        }
        for (n, _) in &r.metrics {
            if !metrics.contains(&n.as_str()) {
                metrics.push(n);
            }
        }
    }
    body.push_str("<h2>Points</h2>\n<table>\n<tr><th>point</th><th>status</th>");
    for n in &params {
        let _ = write!(body, "<th>{}</th>", escape(n));
    }
    for n in &metrics {
        let _ = write!(body, "<th>{}</th>", escape(&super::collect::metric_column(n, &params)));
    }
    body.push_str("<th>wall s</th><th>host</th><th>error</th></tr>\n");
    for r in results {
        let link = if dir.join(&r.name).join(PAGE_FILE).is_file() {
            format!("<a href=\"{}/{}\">{}</a>", href(&r.name), PAGE_FILE, escape(&r.name))
        } else {
            escape(&r.name)
        };
        let label = r.state.label();
        let _ = write!(body, "<tr><td>{link}</td><td class=\"{label}\">{label}</td>");
        for n in &params {
            let v = r.parameters.iter().find(|(k, _)| k == n).map(|(_, v)| v.as_str()).unwrap_or("");
            let _ = write!(body, "<td>{}</td>", escape(v));
        }
        for n in &metrics {
            let v = r.metrics.iter().find(|(k, _)| k == n).map(|(_, v)| format!("{v:.6e}")).unwrap_or_default();
            let _ = write!(body, "<td>{v}</td>");
        }
        let error = match &r.state {
            PointState::Failed(e) => e.clone(),
            _ => r.metrics_error.clone().unwrap_or_default(),
        };
        let _ = writeln!(
            body,
            "<td>{}</td><td>{}</td><td>{}</td></tr>",
            r.wall_s.map(|w| format!("{w:.1}")).unwrap_or_default(),
            escape(r.host.as_deref().unwrap_or("")),
            escape(&error)
        );
    }
    body.push_str("</table>\n");
    body.push_str(&output_sections(&Outputs::of(dir), &[]));
    let path = dir.join(PAGE_FILE);
    crate::atomic_write::write(&path, page(&format!("sweep of {source}"), &body).as_bytes())?;
    Ok(path)
}
