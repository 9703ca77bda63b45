//! Every run folder and every sweep folder gets `index.html`, readable without network
//! access: checked in headless Chromium (Debian's `chromium`) — the page loads, every image
//! resolves (the page's own check, read from the DOM), and nothing is logged to the console.
//! Without Chromium the browser half skips with a note; under `.ci/run`
//! (MATDEM_REQUIRE_CHROMIUM=1) it fails instead.

use crate::common::*;
use std::path::Path;
use std::process::Command;

/// A small scene that writes a chart, a particle picture, a table and a reported metric.
const SCENE: &str = r#"
let b = new_box("page"); b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3; b.seed = 1;
let d = b.build_initial_model(); d.set_standard_dt(); d.gravity = [0.0, 0.0, -9.81];
d.run(200); d.record();
let t = new_table(); t.add_row(#{ step: 1.0, z: d.z.mean() }); t.save("heights.csv");
let c = chart("mean height", "step", "z [m]"); c.series("z", [0.0, 1.0], [d.z.mean(), d.z.mean()]); c.save("height");
d.show("z", "particles");
report("mean_z", d.z.mean());
"#;

fn chromium() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| Command::new(b).arg("--version").output().is_ok_and(|o| o.status.success()));
    if found.is_none() {
        assert!(
            std::env::var_os("MATDEM_REQUIRE_CHROMIUM").is_none(),
            "MATDEM_REQUIRE_CHROMIUM is set but no chromium runs (install Debian's `chromium`)"
        );
        eprintln!("note: no chromium found; the report page's browser check is skipped");
    }
    found
}

/// Loads the page headless; returns the `data-images` the page's own check wrote and the
/// console lines Chromium logged.
fn load(browser: &str, page: &Path) -> (String, Vec<String>) {
    let url = format!("file://{}", page.canonicalize().unwrap().display());
    let o = Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0"])
        .args(["--virtual-time-budget=5000", "--dump-dom"])
        .arg(&url)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .unwrap();
    assert!(o.status.success(), "chromium failed on {url}: {}", String::from_utf8_lossy(&o.stderr));
    let dom = String::from_utf8_lossy(&o.stdout).to_string();
    let images = dom
        .split("data-images=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap_or_else(|| panic!("the page's image check did not run: {dom}"))
        .to_string();
    let console =
        String::from_utf8_lossy(&o.stderr).lines().filter(|l| l.contains(":CONSOLE")).map(String::from).collect();
    (images, console)
}

#[test]
fn a_run_folder_gets_a_page_with_its_record_plan_metrics_charts_and_pictures() {
    let dir = temp_dir("report_page_run");
    let out = dir.join("out");
    std::fs::write(dir.join("scene.rhai"), SCENE).unwrap();
    let o = bin()
        .args(["run", "--backend", "cpu", "--set", "label=<b>x</b>"])
        .arg(dir.join("scene.rhai"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let page = out.join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("<h1>") && html.contains("<span class=\"ok\">ok</span>"), "status shown");
    assert!(html.contains("label=&lt;b&gt;x&lt;/b&gt;") && !html.contains("<b>x</b>"), "parameters escaped");
    assert!(html.contains("Plan of <code>page</code>") && html.contains("step plan:"), "the model's plan");
    assert!(html.contains("<td>mean_z</td>"), "the reported metric");
    assert!(html.contains("<figure><svg"), "the chart inline");
    assert!(html.contains("<img src=\"particles.png\""), "the particle picture as an image");
    assert!(html.contains("heights.csv") && html.contains("run.ron"), "tables and files listed");
    assert!(!html.contains("src=\"http") && !html.contains("href=\"http"), "nothing fetched from the network");
    let Some(browser) = chromium() else { return };
    let (images, console) = load(browser, &page);
    assert_eq!(images, "1 loaded, 0 broken");
    assert!(console.is_empty(), "console: {console:?}");
}

#[test]
fn a_failed_run_still_gets_a_page_that_shows_its_error() {
    let dir = temp_dir("report_page_failed");
    let out = dir.join("out");
    std::fs::write(dir.join("bad.rhai"), "let x = 1;\nthrow \"the load <failed>\";\n").unwrap();
    let o = bin().args(["run", "--backend", "cpu"]).arg(dir.join("bad.rhai")).arg("--out").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(html.contains("<span class=\"failed\">failed</span>"));
    assert!(html.contains("the load &lt;failed&gt;") && html.contains("bad.rhai:2"), "the error, escaped: {html}");
}

#[test]
fn a_sweep_gets_a_page_linking_every_point_page() {
    let dir = temp_dir("report_page_sweep");
    std::fs::write(
        dir.join("inv.rhai"),
        "if params.x == 0 { throw \"x must not be 0\"; }\nreport(\"inverse\", 1.0 / params.x);\n",
    )
    .unwrap();
    let sweep = dir.join("sw");
    let o = bin()
        .args(["sweep", "plan"])
        .arg(dir.join("inv.rhai"))
        .arg("--out")
        .arg(&sweep)
        .args(["--backend", "cpu", "--vary", "x=0,2,4"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bin().args(["sweep", "run"]).arg(&sweep).args(["--local", "-j", "2"]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bin().args(["sweep", "collect"]).arg(&sweep).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let page = sweep.join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("3 point(s): 2 ok, 1 failed"), "{html}");
    assert!(html.contains("x must not be 0"), "the failed point's error");
    let links = html.matches("/index.html\">").count();
    assert_eq!(links, 3, "each point's page linked: {html}");
    for line in html.lines().filter(|l| l.contains("/index.html\">")) {
        let target = line.split("href=\"").nth(1).unwrap().split('"').next().unwrap();
        assert!(sweep.join(target).is_file(), "{target} exists");
    }
    assert!(html.contains("sweep.csv"), "the merged table");
    let Some(browser) = chromium() else { return };
    let (images, console) = load(browser, &page);
    assert_eq!(images, "0 loaded, 0 broken");
    assert!(console.is_empty(), "console: {console:?}");
}
