//! The REPL driven through piped input: variables, functions and models live across lines
//! and across errors; `:help NAME` prints a function's doc; Ctrl-C (SIGINT) cancels the
//! running balance and the session goes on. Every child is killed on every path.

use crate::common::*;
use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Stdio};
use std::sync::mpsc;
use std::time::Duration;

/// Kills the REPL when the test ends, however it ends: a stray session would hang CI.
struct Reaper(Child);

impl Drop for Reaper {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

const SMALL_BOX: &str = r#"let b = new_box("t"); b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.003; b.ball_r = 0.4e-3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("m", #{ kn: 2e5, ks: 8e4, mu_p: 0.3, r: 0.4e-3, restitution: 0.3 }));
d.set_standard_dt();
"#;

fn repl_with_input(name: &str, input: &str) -> std::process::Output {
    repl_in(&temp_dir(name), input)
}

/// A session started in `dir` (its read folder), fed `input`.
fn repl_in(dir: &std::path::Path, input: &str) -> std::process::Output {
    let mut child = bin()
        .args(["repl", "--out"])
        .arg(dir.join("out"))
        .env("MATDEM_HISTORY", dir.join("history"))
        .current_dir(dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    // Dropping stdin is the end of input: the session ends there at the latest.
    let written = child.stdin.take().unwrap().write_all(input.as_bytes());
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || tx.send(child.wait_with_output()));
    match rx.recv_timeout(Duration::from_secs(60)) {
        Ok(out) => {
            written.unwrap();
            out.unwrap()
        }
        Err(_) => {
            let _ = std::process::Command::new("kill").arg("-KILL").arg(pid.to_string()).status();
            panic!("the REPL did not finish its input within 60 s");
        }
    }
}

#[test]
fn a_session_keeps_variables_functions_and_its_model_across_lines_and_errors() {
    let input = format!(
        "let x = 40;\nfn add(a, b) {{\n  a + b\n}}\nadd(x, 2)\nundefined_thing(1)\nlet y = [1,\n 2];\nx + y.len()\n{SMALL_BOX}d.run(10);\nd.nonexistent_field\nd.step\n:quit\nprint(\"not reached\");\n"
    );
    let o = repl_with_input("repl_session", &input);
    assert!(o.status.success(), "{}", stderr(&o));
    let out: Vec<String> = stdout(&o).lines().map(String::from).collect();
    assert_eq!(out, ["42", "42", "10"], "stderr:\n{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("Function not found: undefined_thing") && err.contains("<repl>:1:1"), "{err}");
    assert!(err.contains("nonexistent_field"), "{err}");
}

#[test]
fn help_prints_a_functions_doc_native_or_stdlib() {
    let o = repl_with_input("repl_help", ":help balance\n:help sediment\n:help no_such_fn\n:help setGroupMat\n:help\n");
    let out = stdout(&o);
    // A MatDEM name: ours.
    assert!(out.contains("no function `setGroupMat`: MatDEM's `setGroupMat` is `set_group_mat` here"), "{out}");
    assert!(out.contains("d.balance() / d.balance(\"standard\", n)"), "{out}");
    assert!(out.contains("sediment(d, opts)  (stdlib)") && out.contains("settle under gravity"), "{out}");
    assert!(out.contains("no function `no_such_fn`"), "{out}");
    assert!(out.contains(":load FILE") && out.contains("set_group_mat"), "{out}");
}

#[test]
fn load_runs_a_file_in_the_session() {
    let dir = temp_dir("repl_load_file");
    std::fs::write(dir.join("setup.rhai"), "let loaded = 7; fn twice(v) { 2 * v }").unwrap();
    let o = repl_in(&dir, ":load setup.rhai\ntwice(loaded)\n:load nope.rhai\n");
    assert_eq!(stdout(&o).trim(), "14");
    assert!(stderr(&o).contains("cannot read") && stderr(&o).contains("nope.rhai"), "{}", stderr(&o));
}

#[test]
fn load_reads_only_inside_the_session_folder_and_echoes_nothing_it_refused() {
    let dir = temp_dir("repl_load_escape");
    std::fs::write(dir.parent().unwrap().join("repl_load_escape_secret.rhai"), "let secret = 1;").unwrap();
    let o = repl_in(&dir, ":load /etc/passwd\n:load ../repl_load_escape_secret.rhai\nsecret\n");
    let e = stderr(&o);
    assert!(e.contains("path `/etc/passwd` is outside the allowed folders (an absolute path)"), "{e}");
    assert!(
        e.contains("path `../repl_load_escape_secret.rhai` is outside the allowed folders (`..` climbs out)"),
        "{e}"
    );
    assert!(e.contains("Variable not found: secret"), "the file outside was run:\n{e}");
    assert!(!e.contains("root:") && !stdout(&o).contains("root:"), "/etc/passwd leaked:\n{e}");
}

#[test]
fn every_documented_name_is_a_function_scripts_can_call() {
    let host = std::rc::Rc::new(matdem_rs::api::Host::new(temp_dir("repl_docs")));
    let engine = matdem_rs::new_engine(host);
    let sigs = engine.gen_fn_signatures(false);
    for (name, _, _) in matdem_rs::api::docs::DOCS {
        assert!(sigs.iter().any(|s| s.starts_with(&format!("{name}("))), "docs name `{name}` is not a function");
    }
}

#[test]
fn ctrl_c_cancels_the_running_balance_and_the_session_goes_on() {
    let dir = temp_dir("repl_ctrl_c");
    let child = bin()
        .args(["repl", "--out"])
        .arg(dir.join("out"))
        .env("MATDEM_HISTORY", dir.join("history"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut repl = Reaper(child);
    let mut stdin = repl.0.stdin.take().unwrap();
    let stdout = repl.0.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    // Far more steps than a test could wait for: only a cancel ends it.
    writeln!(stdin, "{SMALL_BOX}print(\"running\"); d.run(1000000000);").unwrap();
    stdin.flush().unwrap();
    let first = rx.recv_timeout(Duration::from_secs(60)).expect("the REPL never started the run");
    assert_eq!(first, "running");
    std::thread::sleep(Duration::from_millis(500));
    let kill = std::process::Command::new("kill").arg("-INT").arg(repl.0.id().to_string()).status().unwrap();
    assert!(kill.success());
    write!(stdin, "print(`alive ${{d.step > 0}}`);\n:quit\n").unwrap();
    stdin.flush().unwrap();
    let alive = rx.recv_timeout(Duration::from_secs(60)).expect("the session did not go on after Ctrl-C");
    assert_eq!(alive, "alive true");
    let status = repl.0.wait().unwrap();
    assert!(status.success());
    let mut err = String::new();
    std::io::Read::read_to_string(&mut repl.0.stderr.take().unwrap(), &mut err).unwrap();
    assert!(err.contains("run cancelled after"), "{err}");
}
