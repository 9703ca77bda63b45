//! The REPL on a real terminal: a pseudo-terminal from util-linux `script` (Debian's
//! essential bsdutils), so rustyline's line editor runs as it does for a user. Tab completes
//! an API name, Ctrl-C at the prompt drops the line being typed, Ctrl-C during a balance
//! cancels the balance (the terminal sends SIGINT) and the session goes on, Ctrl-D ends it.

use crate::common::*;
use std::io::{Read, Write};
use std::process::{Child, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Kills the session when the test ends, however it ends.
struct Reaper(Child);

impl Drop for Reaper {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Everything the terminal has shown so far.
#[derive(Clone, Default)]
struct Screen(Arc<Mutex<String>>);

impl Screen {
    /// Waits until the screen shows `text` after byte `from`; the byte after it.
    fn wait_for(&self, text: &str, from: usize) -> usize {
        let start = Instant::now();
        loop {
            let shown = self.0.lock().unwrap().clone();
            if let Some(k) = shown.get(from..).and_then(|s| s.find(text)) {
                return from + k + text.len();
            }
            assert!(start.elapsed() < Duration::from_secs(60), "the terminal never showed `{text}`:\n{shown}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Waits for a fresh prompt after byte `from`. The editor redraws the line it edits
    /// behind a carriage return, prompt included; a new prompt follows a line feed.
    fn wait_for_prompt(&self, from: usize) -> usize {
        let line_end = self.wait_for("\n", from);
        self.wait_for("matdem> ", line_end)
    }
}

#[test]
fn on_a_terminal_tab_completes_and_ctrl_c_cancels_the_line_or_the_balance_not_the_session() {
    let dir = temp_dir("repl_terminal");
    let command = format!("exec '{}' repl --out '{}'", env!("CARGO_BIN_EXE_matdem-rs"), dir.join("out").display());
    let child = std::process::Command::new("script")
        .args(["-q", "-e", "-c", &command, "/dev/null"])
        .env("TERM", "xterm")
        .env("MATDEM_HISTORY", dir.join("history"))
        .current_dir(&dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("util-linux `script` (package bsdutils) provides the pseudo-terminal");
    let mut term = Reaper(child);
    let mut keys = term.0.stdin.take().unwrap();
    let mut out = term.0.stdout.take().unwrap();
    let screen = Screen::default();
    let sink = screen.clone();
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(n) = out.read(&mut buf) {
            if n == 0 {
                break;
            }
            sink.0.lock().unwrap().push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    });
    let mut type_keys = |s: &str| {
        keys.write_all(s.as_bytes()).unwrap();
        keys.flush().unwrap();
    };
    let mut at = screen.wait_for("matdem> ", 0);

    // Tab turns `new_bo` into `new_box`: without it the line would call an unknown function.
    type_keys("let b = new_bo\t");
    at = screen.wait_for("new_box", at);
    type_keys("(\"t\"); print(`made ${type_of(b)}`);\r");
    at = screen.wait_for("made Box", at);
    // Keys typed before the next prompt is up may be read with the line just ended and
    // dropped with it: wait for each prompt, as a user does.
    at = screen.wait_for_prompt(at);

    // Ctrl-C at the prompt drops the half-typed line, as shells do.
    type_keys("this is not rhai\x03");
    at = screen.wait_for_prompt(at);
    type_keys("print(`line dropped`);\r");
    at = screen.wait_for("line dropped", at);
    at = screen.wait_for_prompt(at);
    assert!(!screen.0.lock().unwrap().contains("Syntax error"), "the dropped line ran");

    // Ctrl-C during a balance: the terminal sends SIGINT, the balance stops, the session stays.
    for line in [
        "b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.003; b.ball_r = 0.4e-3;",
        "let d = b.build_initial_model();",
        "d.set_group_mat(\"sample\", material_micro(\"m\", #{ kn: 2e5, ks: 8e4, mu_p: 0.3, r: 0.4e-3, restitution: 0.3 }));",
        "d.set_standard_dt();",
        "print(`running`); d.run(1000000000);",
    ] {
        type_keys(&format!("{line}\r"));
        at = if line.contains("running") { screen.wait_for("\r\nrunning", at) } else { screen.wait_for_prompt(at) };
    }
    std::thread::sleep(Duration::from_millis(300));
    type_keys("\x03");
    at = screen.wait_for("run cancelled after", at);
    at = screen.wait_for_prompt(at);
    type_keys("print(`alive ${d.step > 0}`);\r");
    at = screen.wait_for("alive true", at);
    screen.wait_for_prompt(at);

    // Ctrl-D on an empty line ends the session.
    type_keys("\x04");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = term.0.try_wait().unwrap() {
            break s;
        }
        assert!(start.elapsed() < Duration::from_secs(30), "Ctrl-D did not end the session");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "{status}");
    let history = std::fs::read_to_string(dir.join("history")).unwrap_or_default();
    assert!(history.contains("print(`alive ${d.step > 0}`);"), "history kept:\n{history}");
}
