//! `matdem-rs repl`: an interactive session that keeps its variables, functions and models
//! alive between lines. Line editing, history and completion come from rustyline on a
//! terminal; piped input is read line by line. Ctrl-C cancels the running balance (the
//! engine checks a flag between step chunks) or the running script, never the session.

use crate::api::docs;
use crate::api::Host;
use crate::report::{render, Sources};
use crate::sandbox::{Limits, ReadRoot};
use crate::{eout, eoutln, outln};
use rhai::{Dynamic, Engine, Scope, AST};
use std::io::{BufRead, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// What `matdem-rs repl` was asked for.
pub struct ReplConfig {
    /// A script to run first; its folder is the session's read folder.
    pub script: Option<PathBuf>,
    pub out_dir: PathBuf,
    pub limits: Limits,
}

/// What one line of input gave.
#[derive(Debug, PartialEq)]
pub enum Reply {
    /// Text for stdout (a value, help); may be empty.
    Out(String),
    /// A rendered error for stderr; the session goes on.
    Err(String),
    Quit,
}

/// One live session: the engine, its scope and the functions defined so far.
pub struct Session {
    engine: Engine,
    scope: Scope<'static>,
    functions: AST,
    cancel: Arc<AtomicBool>,
    /// `:load` reads through the host's sandbox, as `import` and `read_text` do.
    host: Rc<Host>,
    /// Held for the session: one writer per output folder.
    _lock: crate::out_lock::OutLock,
    names: Vec<String>,
    stdlib_docs: Vec<(String, String)>,
}

const COMMANDS: &str = "\
:help           this list
:help NAME      what a function does and how to call it
:vars           the session's variables
:load FILE      run a script file in this session
:quit           leave (or Ctrl-D)
A line with unbalanced brackets, or ending in `\\`, continues on the next line.
Ctrl-C cancels the running balance or script; the session and its models stay.";

impl Session {
    pub fn new(out_dir: PathBuf, read_root: ReadRoot, limits: Limits) -> Result<Session, String> {
        let lock = crate::out_lock::OutLock::acquire(&out_dir, "repl")?;
        let mut host = Host::new(out_dir.clone());
        host.read_root = read_root;
        host.limits = limits;
        let cancel = host.control.cancel.clone();
        let host = Rc::new(host);
        let mut engine = crate::new_engine(host.clone());
        // Script loops are cancelled here; native balances check the same flag.
        let flag = cancel.clone();
        engine.on_progress(move |_| {
            if flag.load(Ordering::Relaxed) {
                Some(Dynamic::from("cancelled by Ctrl-C"))
            } else {
                crate::memory::over_limit()
            }
        });
        let mut scope = Scope::new();
        scope.push_constant("params", rhai::Map::new());
        scope.push_constant("out_dir", out_dir.display().to_string());
        let mut names: Vec<String> = engine
            .gen_fn_signatures(false)
            .iter()
            .filter_map(|s| s.split('(').next())
            .filter(|n| n.chars().all(|c| c.is_alphanumeric() || c == '_'))
            .map(String::from)
            .collect();
        let stdlib_docs = crate::api::reference::stdlib_docs(&engine);
        names.extend(stdlib_docs.iter().map(|(n, _)| n.clone()));
        names.extend(docs::functions().map(|(n, _, _)| n.to_string()));
        names.extend([":help", ":vars", ":load", ":quit"].map(String::from));
        names.sort();
        names.dedup();
        Ok(Session { engine, scope, functions: AST::empty(), cancel, host, _lock: lock, names, stdlib_docs })
    }

    /// The flag Ctrl-C sets.
    pub fn cancel_flag(&self) -> Arc<AtomicBool> {
        self.cancel.clone()
    }

    /// Every name completion offers.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Evaluates one complete input (code or a `:command`).
    pub fn eval_input(&mut self, input: &str) -> Reply {
        let line = input.trim();
        if let Some(cmd) = line.strip_prefix(':') {
            let (name, arg) = cmd.split_once(char::is_whitespace).map_or((cmd, ""), |(a, b)| (a, b.trim()));
            return match name {
                "q" | "quit" | "exit" => Reply::Quit,
                "help" | "h" if arg.is_empty() => {
                    Reply::Out(format!("{COMMANDS}\n\nfunctions: {}", self.function_list()))
                }
                "help" | "h" => Reply::Out(self.help(arg)),
                "vars" => Reply::Out(self.vars()),
                "load" if !arg.is_empty() => match self.host.read_root.read(arg) {
                    Ok(bytes) => match String::from_utf8(bytes) {
                        Ok(text) => self.eval_code(&text, arg),
                        Err(_) => Reply::Err(format!("error: cannot load `{arg}`: it is not UTF-8 text")),
                    },
                    Err(e) => Reply::Err(format!("error: cannot load: {e}")),
                },
                "load" => {
                    Reply::Err("error: :load needs a file: `:load FILE` (a script in this session's folder)".into())
                }
                _ => Reply::Err(format!("error: unknown command `:{cmd}`; try :help")),
            };
        }
        if line.is_empty() {
            return Reply::Out(String::new());
        }
        self.eval_code(input, "<repl>")
    }

    fn eval_code(&mut self, code: &str, label: &str) -> Reply {
        self.cancel.store(false, Ordering::Relaxed);
        let sources = Sources { main_path: label, main_text: code, hint: crate::api::hints::for_error };
        self.host.limits.compiling(&mut self.engine);
        let ast = match self.engine.compile_with_scope(&self.scope, code) {
            Ok(a) => a,
            Err(e) => return Reply::Err(render(&e.into(), &sources)),
        };
        self.host.limits.running(&mut self.engine);
        // Functions defined on earlier lines stay callable.
        let merged = self.functions.merge(&ast);
        let result = self.engine.eval_ast_with_scope::<Dynamic>(&mut self.scope, &merged);
        self.functions = merged.clone_functions_only();
        self.cancel.store(false, Ordering::Relaxed);
        // As in Rust, a trailing `;` means "no value to show".
        let quiet = code.trim_end().ends_with(';');
        match result {
            Ok(v) if v.is_unit() || quiet => Reply::Out(String::new()),
            Ok(v) => Reply::Out(self.show(v)),
            Err(e) => Reply::Err(render(&e, &sources)),
        }
    }

    /// A value as a person reads it: strings bare, everything else through `to_string`.
    fn show(&self, v: Dynamic) -> String {
        if v.is_string() {
            return v.to_string();
        }
        let mut scope = Scope::new();
        scope.push("v", v.clone());
        self.engine.eval_with_scope::<String>(&mut scope, "`${v}`").unwrap_or_else(|_| format!("{v:?}"))
    }

    fn help(&self, name: &str) -> String {
        if let Some((usage, doc)) = docs::lookup(name) {
            return format!("{usage}\n  {doc}");
        }
        if let Some((_, doc)) = self.stdlib_docs.iter().find(|(n, _)| n == name) {
            return doc.clone();
        }
        let sigs: Vec<String> = self
            .engine
            .gen_fn_signatures(false)
            .into_iter()
            .filter(|s| s.split('(').next() == Some(name) || s.starts_with(&format!("get${name}(")))
            .collect();
        if sigs.is_empty() {
            match crate::api::hints::for_name(name) {
                Some(hint) => format!("no function `{name}`: {hint}; :help lists them"),
                None => format!("no function `{name}`; :help lists them"),
            }
        } else {
            sigs.join("\n")
        }
    }

    fn function_list(&self) -> String {
        self.names.iter().filter(|n| !n.starts_with(':')).cloned().collect::<Vec<_>>().join(" ")
    }

    fn vars(&self) -> String {
        self.scope
            .iter_raw()
            .map(|(name, constant, v)| format!("{}{name}: {}", if constant { "const " } else { "" }, v.type_name()))
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// (name, doc comment) of each stdlib procedure, from the scripts' `///` comments.
/// True when `text` still needs lines: open brackets, an open string, or a trailing `\`.
pub fn needs_more(text: &str) -> bool {
    if text.trim_end().ends_with('\\') {
        return true;
    }
    let mut depth = 0i64;
    let mut quote: Option<char> = None;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match quote {
            Some(q) => {
                if c == '\\' {
                    chars.next();
                } else if c == q {
                    quote = None;
                }
            }
            None => match c {
                '"' | '`' | '\'' => quote = Some(c),
                '/' if chars.peek() == Some(&'/') => {
                    // A comment runs to the end of its line.
                    for c in chars.by_ref() {
                        if c == '\n' {
                            break;
                        }
                    }
                }
                '(' | '[' | '{' => depth += 1,
                ')' | ']' | '}' => depth -= 1,
                _ => {}
            },
        }
    }
    depth > 0 || matches!(quote, Some('`'))
}

/// Joins continued lines: a trailing `\` is dropped.
fn push_line(buf: &mut String, line: &str) {
    let line = line.trim_end_matches(['\n', '\r']);
    let line = line.strip_suffix('\\').unwrap_or(line);
    if !buf.is_empty() {
        buf.push('\n');
    }
    buf.push_str(line);
}

/// Where the history is kept: `$MATDEM_HISTORY`, else the user's data folder, else ~/.matdem_history.
fn history_path() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MATDEM_HISTORY") {
        return Some(PathBuf::from(p));
    }
    if let Some(d) = std::env::var_os("XDG_DATA_HOME").filter(|d| !d.is_empty()) {
        return Some(Path::new(&d).join("matdem-rs").join("history"));
    }
    std::env::var_os("HOME").map(|h| Path::new(&h).join(".matdem_history"))
}

/// Runs the session until `:quit` or end of input. Returns the process's exit code.
pub fn run_repl(cfg: ReplConfig) -> Result<u8, String> {
    let read_dir = match &cfg.script {
        Some(s) => s.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf(),
        None => PathBuf::from("."),
    };
    let root = ReadRoot::folder(&read_dir).map_err(|e| format!("cannot open {}: {e}", read_dir.display()))?;
    let mut session = Session::new(cfg.out_dir.clone(), root, cfg.limits)?;
    let flag = session.cancel_flag();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)).map_err(|e| format!("cannot catch Ctrl-C: {e}"))?;
    if let Some(script) = &cfg.script {
        // The session reads inside the script's folder, where the script is by its name.
        let name = script.file_name().map(Path::new).unwrap_or(script);
        if !report(session.eval_input(&format!(":load {}", name.display()))) {
            return Ok(0);
        }
    }
    if std::io::stdin().is_terminal() {
        interactive(&mut session)
    } else {
        piped(&mut session)
    }
}

/// Prints a reply; false once the session should end.
fn report(reply: Reply) -> bool {
    match reply {
        Reply::Out(s) if s.is_empty() => true,
        Reply::Out(s) => {
            outln!("{}", crate::terminal_text::lines(&s));
            true
        }
        Reply::Err(e) => {
            eout!("{}", crate::terminal_text::lines(&e));
            if !e.ends_with('\n') {
                eoutln!();
            }
            true
        }
        Reply::Quit => false,
    }
}

fn piped(session: &mut Session) -> Result<u8, String> {
    let stdin = std::io::stdin();
    let mut buf = String::new();
    for line in stdin.lock().lines() {
        let line = line.map_err(|e| format!("cannot read input: {e}"))?;
        push_line(&mut buf, &line);
        if needs_more(&buf) && !line.trim_start().starts_with(':') {
            continue;
        }
        let input = std::mem::take(&mut buf);
        let go_on = report(session.eval_input(&input));
        let _ = std::io::stdout().flush();
        if !go_on {
            return Ok(0);
        }
    }
    if !buf.trim().is_empty() {
        report(session.eval_input(&buf));
    }
    Ok(0)
}

fn interactive(session: &mut Session) -> Result<u8, String> {
    use rustyline::error::ReadlineError;
    let mut editor = rustyline::Editor::<Completion, rustyline::history::DefaultHistory>::new()
        .map_err(|e| format!("cannot start the line editor: {e}"))?;
    editor.set_helper(Some(Completion { names: session.names().to_vec() }));
    let history = history_path();
    if let Some(h) = &history {
        let _ = editor.load_history(h);
    }
    outln!("matdem-rs {} — :help for commands and functions, :quit to leave", env!("CARGO_PKG_VERSION"));
    let mut buf = String::new();
    loop {
        let prompt = if buf.is_empty() { "matdem> " } else { "   ...> " };
        match editor.readline(prompt) {
            Ok(line) => {
                push_line(&mut buf, &line);
                if needs_more(&buf) && !line.trim_start().starts_with(':') {
                    continue;
                }
                let input = std::mem::take(&mut buf);
                let _ = editor.add_history_entry(input.as_str());
                if !report(session.eval_input(&input)) {
                    break;
                }
            }
            // Ctrl-C at the prompt drops the line being typed, as shells do.
            Err(ReadlineError::Interrupted) => buf.clear(),
            Err(ReadlineError::Eof) => break,
            Err(e) => return Err(format!("cannot read input: {e}")),
        }
    }
    if let Some(h) = &history {
        if let Some(dir) = h.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        let _ = editor.save_history(h);
    }
    Ok(0)
}

/// Completes API names and `:commands` at the cursor.
#[derive(rustyline::Helper, rustyline::Hinter, rustyline::Highlighter, rustyline::Validator)]
struct Completion {
    names: Vec<String>,
}

impl rustyline::completion::Completer for Completion {
    type Candidate = String;

    fn complete(
        &self,
        line: &str,
        pos: usize,
        _ctx: &rustyline::Context<'_>,
    ) -> rustyline::Result<(usize, Vec<String>)> {
        let start = line[..pos].rfind(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).map_or(0, |k| k + 1);
        let word = &line[start..pos];
        if word.is_empty() {
            return Ok((pos, Vec::new()));
        }
        Ok((start, self.names.iter().filter(|n| n.starts_with(word)).cloned().collect()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn open_brackets_strings_and_trailing_backslashes_continue_the_input() {
        assert!(needs_more("fn f(x) {"));
        assert!(needs_more("let a = [1,\n2"));
        assert!(needs_more("let s = `a\n"));
        assert!(needs_more("let x = 1 + \\"));
        assert!(!needs_more("let s = \"{\"; // {"));
        assert!(!needs_more("fn f(x) {\n x + 1\n}"));
    }
}
