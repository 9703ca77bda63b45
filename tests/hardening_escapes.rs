//! Hardening II (issue 28): text from a script, a package or a sweep folder reaches the
//! terminal with its control characters shown, not obeyed; a script cannot save over the
//! host's own files; ambiguous tables, degenerate statistics and values that overflow are
//! refused with a message instead of being accepted in silence or panicking.

use crate::common::*;
use std::path::Path;
use std::process::Output;

/// The hostile text of the issue: an OSC 52 clipboard write, a screen clear, a bidi
/// override and a fake status line. Rhai's escapes, so the script holds the raw characters.
const HOSTILE: &str = r"\x1b]52;c;aGVsbG8=\x07\x1b[2J\u202eFAKE: all points ok";

/// Characters a terminal obeys rather than shows (newlines and tabs allowed where `layout`).
fn obeyed(c: char, layout: bool) -> bool {
    match c {
        '\n' | '\t' => !layout,
        '\u{0}'..='\u{1f}' | '\u{7f}'..='\u{9f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' => true,
        _ => false,
    }
}

fn assert_shown_not_obeyed(text: &str, what: &str) {
    if let Some(c) = text.chars().find(|&c| obeyed(c, true)) {
        panic!("{what} holds a raw {:?}:\n{}", c, text.escape_debug());
    }
}

fn assert_terminal_safe(o: &Output, what: &str) {
    assert_shown_not_obeyed(&stdout(o), &format!("{what} (stdout)"));
    assert_shown_not_obeyed(&stderr(o), &format!("{what} (stderr)"));
}

// Before the fix: stdout held the raw ESC of `print` (`a\u{1b}[2Jb`), and stderr the raw
// OSC 52, BEL, ESC [2J and U+202E of the thrown message and of the source line quoted under
// it. (`debug` of a string was shown escaped already, by Rhai's own `{:?}`.)
#[test]
fn a_scripts_print_debug_and_error_show_control_characters_as_escapes() {
    let dir = temp_dir("escapes_run");
    let script = format!(
        "print(\"a\\x1b[2Jb\\tc\\nd\");\ndebug(\"x\\x1b[31my\");\nthrow \"{HOSTILE}\"; // \u{1b}[2J \u{202e}kept as written\n"
    );
    let o = run_script(&dir, "p.rhai", &script, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_terminal_safe(&o, "run");
    let (out, err) = (stdout(&o), stderr(&o));
    // Newlines and tabs of `print` stay; the escape is shown.
    assert!(out.contains("a\\x1b[2Jb\tc\nd"), "{out}");
    assert!(out.contains("x\\u{1b}[31my"), "{out}");
    assert!(err.contains("error: \\x1b]52;c;aGVsbG8=\\x07\\x1b[2J\\u{202e}FAKE: all points ok"), "{err}");
    // The quoted source line shows its raw characters escaped, the caret still under `throw`.
    let line = err.lines().find(|l| l.starts_with("3 │ ")).unwrap_or_else(|| panic!("no source line: {err}"));
    assert!(line.contains("// \\x1b[2J \\u{202e}kept as written"), "{line}");
}

fn sweep(args: &[&str], dir: &Path) -> Output {
    bin().arg("sweep").args(args).arg(dir).output().unwrap()
}

// Before the fix: `sweep run` and `sweep status` printed the point's error with its raw
// OSC 52, BEL, ESC [2J and U+202E, a hand-made outcome's too, and a parameter value's ESC.
#[test]
fn sweep_run_and_status_show_a_points_error_and_values_with_escapes() {
    let dir = temp_dir("escapes_sweep");
    let script = dir.join("hostile.rhai");
    std::fs::write(&script, format!("if params.x == 1 {{ throw \"{HOSTILE}\"; }}\nreport(\"m\", 1.0);\n")).unwrap();
    let sw = dir.join("sw");
    let plan = bin()
        .args(["sweep", "plan"])
        .arg(&script)
        .arg("--out")
        .arg(&sw)
        .args(["--backend", "cpu", "--vary", "x=1,2", "--vary", "s=a\u{1b}[2Jb"])
        .output()
        .unwrap();
    assert!(plan.status.success(), "{}", stderr(&plan));
    let run = sweep(&["run", "--local"], &sw);
    assert!(run.status.success(), "{}", stderr(&run));
    assert_terminal_safe(&run, "sweep run");
    assert!(stderr(&run).contains("\\x1b]52;c;") && stderr(&run).contains("s=a\\x1b[2Jb"), "{}", stderr(&run));
    // An outcome written by hand (or by another tool) is escaped where it is shown.
    let hostile = matdem_rs::sweep::point::Outcome {
        status: matdem_rs::sweep::point::PointStatus::Failed,
        error: Some("error: \u{1b}]52;c;aGk=\u{7}\u{1b}[2J\u{202e}FAKE\nall points ok".into()),
        exit_code: Some(1),
        wall_s: 0.1,
        host: "h".into(),
        started: "s".into(),
        finished: "f".into(),
    };
    let text = ron::ser::to_string(&hostile).unwrap();
    std::fs::write(sw.join("outcomes/run01.ron"), text).unwrap();
    for action in ["status", "collect"] {
        let o = sweep(&[action], &sw);
        assert!(o.status.success(), "{action}: {}", stderr(&o));
        assert_terminal_safe(&o, action);
        let out = stdout(&o);
        assert!(out.contains("failed: error: \\x1b]52;c;aGk=\\x07\\x1b[2J\\u{202e}FAKE\\nall points ok"), "{out}");
    }
    // The file keeps the raw text: only terminals need escapes.
    assert!(std::fs::read_to_string(sw.join("sweep.csv")).unwrap().contains('\u{1b}'));
}

// Before the fix: the REPL echoed the string's ESC [2J raw, and the error's OSC 52 and BEL.
#[test]
fn the_repl_echoes_results_and_errors_with_escapes() {
    let dir = temp_dir("escapes_repl");
    let mut child = bin()
        .args(["repl", "--out"])
        .arg(dir.join("out"))
        .env("MATDEM_HISTORY", dir.join("history"))
        .current_dir(&dir)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    let input = format!("\"a\\x1b[2Jb\"\nthrow \"{HOSTILE}\";\n");
    child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    let o = child.wait_with_output().unwrap();
    assert_terminal_safe(&o, "repl");
    assert!(stdout(&o).contains("a\\x1b[2Jb"), "{}", stdout(&o));
    assert!(stderr(&o).contains("\\x1b]52;c;aGVsbG8=\\x07"), "{}", stderr(&o));
}

// Before the fix: `info` printed the manifest's description and help with their raw
// ESC [2J, BEL and U+202E.
#[test]
fn info_shows_a_manifests_control_characters_as_escapes() {
    let dir = temp_dir("escapes_info");
    let pkg = dir.join("pkg");
    std::fs::create_dir_all(&pkg).unwrap();
    std::fs::write(
        pkg.join("simulator.ron"),
        "(name: \"pkg\", version: \"1.0.0\", description: \"adds\u{1b}[2J one\u{7}\", entry: \"main.rhai\",
          parameters: [(name: \"n\", type: int, default: 1, help: \"a \u{202e}count\", unit: \"\u{1b}[31mm\")])",
    )
    .unwrap();
    std::fs::write(pkg.join("main.rhai"), "print(params.n);").unwrap();
    let o = bin().arg("info").arg(&pkg).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_terminal_safe(&o, "info");
    let out = stdout(&o);
    assert!(out.contains("adds\\x1b[2J one\\x07") && out.contains("a \\u{202e}count"), "{out}");
}

// Before the fix: the study's progress and summary printed the varied value's raw ESC [2J.
#[test]
fn a_studys_output_shows_a_values_control_characters_as_escapes() {
    let dir = temp_dir("escapes_study");
    let script = dir.join("s.rhai");
    std::fs::write(&script, "report(\"m\", 1.0);").unwrap();
    let o = bin()
        .arg("study")
        .arg(&script)
        .args(["--vary", "x=1,a\u{1b}[2Jb", "--metric", "m", "--backend", "cpu", "--out"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_terminal_safe(&o, "study");
    assert!(stdout(&o).contains("x=a\\x1b[2Jb"), "{}", stdout(&o));
}

// Before the fix: `t.save("index.html")` printed "wrote 1 file(s)" and the report page
// replaced it; a table saved as metrics.csv or log.txt, and a checkpoint saved as index.html,
// were accepted the same way (exit 0 each). run.ron was refused already.
#[test]
fn a_save_over_a_name_the_host_writes_is_refused_naming_it() {
    let dir = temp_dir("escapes_reserved");
    let saves = [
        ("let t = new_table(); t.add_row(#{a: 1}); t.save(\"index.html\");", "index.html"),
        ("let t = new_table(); t.add_row(#{a: 1}); t.save(\"Index.HTML\");", "index.html"),
        ("let t = new_table(); t.add_row(#{a: 1}); t.save(\"metrics.csv\");", "metrics.csv"),
        ("let t = new_table(); t.add_row(#{a: 1}); t.save(\"log.txt\");", "log.txt"),
        ("let t = new_table(); t.add_row(#{a: 1}); t.save(\"run.ron\");", "run.ron"),
        (&format!("{SMALL_BOX} d.save(\"index.html\");"), "index.html"),
    ];
    for (script, reserved) in saves {
        let o = run_script(&dir, "p.rhai", script, &[]);
        assert_eq!(o.status.code(), Some(1), "{script}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(&format!("`{reserved}`")) && e.contains("choose another name"), "{script}: {e}");
    }
    // The host's own files are still written: the metrics and the page.
    let o = run_script(&dir, "p.rhai", "report(\"m\", 1.0);", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("out/metrics.csv").is_file() && dir.join("out/index.html").is_file());
}

// Before the fix: `y,x,z,x` loaded with one column `x` (exit 0; `x,x\n1,2` saved back as
// `x\n1`); a cell `1e400` loaded as inf (printed `inf`, exit 0).
#[test]
fn load_table_refuses_a_duplicate_column_and_a_cell_beyond_f64() {
    let dir = temp_dir("escapes_load_table");
    std::fs::write(dir.join("d.csv"), "y,x,z,x\n1,2,3,4\n").unwrap();
    let o = run_script(&dir, "p.rhai", "let t = load_table(\"d.csv\"); t.save(\"back.csv\");", &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("column `x` is given twice (columns 2 and 4)"), "{}", stderr(&o));
    std::fs::write(dir.join("d.csv"), "x,y\n1,1e400\n").unwrap();
    let o = run_script(&dir, "p.rhai", "let t = load_table(\"d.csv\"); print(t[\"y\"][0]);", &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("line 2, column `y`: `1e400` is beyond"), "{}", stderr(&o));
}

// Before the fix: `--vary run=1,2` planned (exit 0) and sweep.csv had two `run` columns.
#[test]
fn a_parameter_named_like_a_sweep_table_column_is_refused_at_plan_time() {
    let dir = temp_dir("escapes_plan_names");
    let script = dir.join("s.rhai");
    std::fs::write(&script, "report(\"m\", 1.0);").unwrap();
    for name in ["run", "status", "note"] {
        let o = bin()
            .args(["sweep", "plan"])
            .arg(&script)
            .arg("--out")
            .arg(dir.join(name))
            .args(["--vary", &format!("{name}=1,2")])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains(&format!("parameter `{name}` would be ambiguous")), "{}", stderr(&o));
    }
    std::fs::write(dir.join("runs.csv"), "status\n1\n").unwrap();
    let o = bin()
        .args(["sweep", "plan"])
        .arg(&script)
        .arg("--out")
        .arg(dir.join("csv"))
        .arg("--runs")
        .arg(dir.join("runs.csv"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("parameter `status` would be ambiguous"), "{}", stderr(&o));
}

// Before the fix: the header read `run,a,status,a,run,status,note,b,note`.
#[test]
fn metrics_named_like_a_column_or_a_parameter_are_prefixed_in_sweep_csv() {
    let dir = temp_dir("escapes_metric_names");
    let script = dir.join("s.rhai");
    std::fs::write(
        &script,
        "report(\"a\", 2.0); report(\"run\", 3.0); report(\"status\", 4.0); report(\"note\", 5.0); report(\"b\", 6.0);",
    )
    .unwrap();
    let sw = dir.join("sw");
    let plan = bin()
        .args(["sweep", "plan"])
        .arg(&script)
        .arg("--out")
        .arg(&sw)
        .args(["--backend", "cpu", "--vary", "a=1"])
        .output()
        .unwrap();
    assert!(plan.status.success(), "{}", stderr(&plan));
    let run = bin().args(["sweep", "run", "--local"]).arg(&sw).output().unwrap();
    assert!(run.status.success(), "{}", stderr(&run));
    let o = sweep(&["collect"], &sw);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = std::fs::read_to_string(sw.join("sweep.csv")).unwrap();
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines[0], "run,a,status,metric:a,metric:run,metric:status,metric:note,b,note", "{table}");
    assert_eq!(lines[1], "run01,1,ok,2.0,3.0,4.0,5.0,6.0,", "{table}");
}

// Before the fix: constant responses, and responses all 1e308, panicked in statrs (beta.rs:131,
// exit 101); alternating ±1e308 gave SS = inf, F = inf and p = 0 (`**`) for every factor.
#[test]
fn anova_of_constant_or_overflowing_responses_is_an_error_not_a_panic() {
    let dir = temp_dir("escapes_anova");
    let design = "let d = orthogonal_design([\"a\", \"b\"], [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]]);";
    let o =
        run_script(&dir, "p.rhai", &format!("{design} d.anova([5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0]);"), &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("all 9 responses are 5"), "{}", stderr(&o));
    for huge in [
        "[1e308, -1e308, 1e308, -1e308, 1e308, -1e308, 1e308, -1e308, 1e308]",
        "[1e308, 1e308, 1e308, 1e308, 1e308, 1e308, 1e308, 1e308, 1e308]",
    ] {
        let o = run_script(&dir, "p.rhai", &format!("{design} print(d.anova({huge}));"), &[]);
        assert_eq!(o.status.code(), Some(1), "{huge}: {}", stderr(&o));
        assert!(stderr(&o).contains("too large") && stderr(&o).contains("scale"), "{}", stderr(&o));
    }
}

// Before the fix: the flat fit's invert(6.0) printed `inf`, the exponential's invert(-1.0)
// `NaN` (exit 0 each).
#[test]
fn inverting_a_flat_regression_is_an_error() {
    let dir = temp_dir("escapes_invert");
    let o = run_script(
        &dir,
        "p.rhai",
        "let r = regress([1.0, 2.0, 3.0], [5.0, 5.0, 5.0], \"linear\"); print(r.invert(6.0));",
        &[],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stderr(&o).contains("is flat") && stderr(&o).contains("no x gives y = 6"), "{}", stderr(&o));
    let o = run_script(
        &dir,
        "p.rhai",
        "let r = regress([1.0, 2.0, 3.0], [2.0, 4.0, 8.0], \"exponential\"); print(r.invert(-1.0));",
        &[],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stderr(&o).contains("no x gives y = -1"), "{}", stderr(&o));
}

// Before the fix: each was accepted (exit 0): two factors `a` in one design, a NaN metric
// (metrics.csv held `m,NaN`), a group named "", and `--set x=1e400` (the script printed inf).
#[test]
fn silent_acceptances_are_refused_with_a_message() {
    let dir = temp_dir("escapes_silent");
    let cases = [
        ("orthogonal_design([\"a\", \"a\"], [[1.0, 2.0], [1.0, 2.0]]);", "factor `a` is named twice"),
        ("report(\"m\", 0.0 / 0.0);", "report: `m` is NaN"),
        (&format!("{SMALL_BOX} d.add_group(\"\", [0]);"), "add_group: a group needs a name"),
    ];
    for (script, message) in cases {
        let o = run_script(&dir, "p.rhai", script, &[]);
        assert_eq!(o.status.code(), Some(1), "{script}: {}", stderr(&o));
        assert!(stderr(&o).contains(message), "{script}: {}", stderr(&o));
    }
    let o = run_script(&dir, "p.rhai", "print(params.x);", &["--set", "x=1e400"]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(stderr(&o).contains("--set x=1e400: `1e400` is not a finite number"), "{}", stderr(&o));
}
