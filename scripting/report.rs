//! Renders script errors the way compilers do: the message, then file:line:column, the
//! source line and a caret under the column; calls into the stdlib are listed below.

use rhai::{EvalAltResult, Position};

/// Where the script's text came from, to quote lines in reports.
pub struct Sources<'a> {
    pub main_path: &'a str,
    pub main_text: &'a str,
}

impl Sources<'_> {
    fn text(&self, source: &str) -> Option<(String, &str)> {
        if source.is_empty() {
            return Some((self.main_path.to_string(), self.main_text));
        }
        crate::stdlib::source(source).map(|t| (format!("<{source}>"), t))
    }
}

/// The innermost error and the chain of calls leading to it: (function, source, position).
fn unwind(e: &EvalAltResult) -> (&EvalAltResult, Vec<(String, String, Position)>) {
    let mut chain = Vec::new();
    let mut cur = e;
    loop {
        match cur {
            EvalAltResult::ErrorInFunctionCall(name, src, inner, pos) => {
                chain.push((name.clone(), src.clone(), *pos));
                cur = inner;
            }
            EvalAltResult::ErrorInModule(name, inner, pos) => {
                chain.push((format!("import \"{name}\""), String::new(), *pos));
                cur = inner;
            }
            _ => return (cur, chain),
        }
    }
}

/// The message of an error without Rhai's "(line x, position y)" suffix.
pub fn message(e: &EvalAltResult) -> String {
    match e {
        EvalAltResult::ErrorRuntime(v, _) => v.to_string(),
        // The sandbox's limits: say which one and how to raise it when the work is real.
        EvalAltResult::ErrorTooManyOperations(_) => "too many operations: the script ran past the sandbox's \
            operation limit (an endless loop?); if the work is real, raise it with --max-operations N"
            .to_string(),
        EvalAltResult::ErrorStackOverflow(_) => "too many nested function calls: the script ran past the \
            sandbox's call depth (endless recursion?); if it is real, raise it with --max-call-depth N"
            .to_string(),
        EvalAltResult::ErrorDataTooLarge(what, _) => {
            let flag = match what.as_str() {
                w if w.contains("rray") => "--max-array-size",
                w if w.contains("tring") => "--max-string-size",
                w if w.contains("ap") => "--max-map-size",
                _ => "--max-array-size, --max-string-size or --max-map-size",
            };
            format!("{what} too large for the sandbox's limit; if it is real, raise it with {flag} N")
        }
        other => {
            let s = other.to_string();
            // Drop the " (line x, position y)" suffix; the snippet shows the position.
            match s.rfind(" (line ") {
                Some(k) if s.ends_with(')') => s[..k].to_string(),
                _ => s,
            }
        }
    }
}

/// A full report: `error: …`, the location with a caret, then the call chain.
pub fn render(e: &EvalAltResult, sources: &Sources<'_>) -> String {
    let (inner, chain) = unwind(e);
    let mut out = format!("error: {}\n", message(inner));
    // The innermost position belongs to the innermost call's source (a stdlib module or the
    // script); the outer calls are in the script that made them.
    let inner_source = chain.last().map(|(_, s, _)| s.clone()).unwrap_or_default();
    out.push_str(&snippet(sources, &inner_source, inner.position()));
    for (k, (name, _, pos)) in chain.iter().enumerate().rev() {
        let caller_src = if k == 0 { String::new() } else { chain[k - 1].1.clone() };
        out.push_str(&format!("  = in call to `{name}`\n"));
        out.push_str(&snippet(sources, &caller_src, *pos));
    }
    out
}

fn snippet(sources: &Sources<'_>, source: &str, pos: Position) -> String {
    let (Some(line), Some((path, text))) = (pos.line(), sources.text(source)) else {
        return String::new();
    };
    let col = pos.position().unwrap_or(1);
    let code = text.lines().nth(line - 1).unwrap_or("");
    let w = line.to_string().len();
    let pad = " ".repeat(w);
    // Keep the caret under the character even when the line has tabs.
    let lead: String = code.chars().take(col.saturating_sub(1)).map(|c| if c == '\t' { '\t' } else { ' ' }).collect();
    format!("{pad} ┌─ {path}:{line}:{col}\n{pad} │\n{line} │ {code}\n{pad} │ {lead}^\n")
}
