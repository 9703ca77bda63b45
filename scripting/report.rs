//! Renders script errors the way compilers do: the message, then file:line:column, the
//! source line and a caret under the column; calls into the stdlib are listed below.
//! Reports go to a terminal: what they quote (the message, the source line, names) has its
//! control characters shown as escapes ([`crate::terminal_text`]).

use crate::terminal_text;
use rhai::{EvalAltResult, Position};

/// Where the script's text came from, to quote lines in reports, and what to suggest.
pub struct Sources<'a> {
    pub main_path: &'a str,
    pub main_text: &'a str,
    /// What to write instead, for an error the script API can advise on (a name it does not
    /// have: `api::hints::for_error`), given the error and the text of the script it is in;
    /// the report's `= help:` line.
    pub hint: fn(&EvalAltResult, &str) -> Option<String>,
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
        EvalAltResult::ErrorTerminated(token, _) if token.is::<crate::memory::OverLimit>() => {
            token.clone().cast::<crate::memory::OverLimit>().message()
        }
        EvalAltResult::ErrorDataTooLarge(what, _) => {
            format!("{what} too large for the sandbox's limit; if it is real, raise it with {} N", size_flag(what))
        }
        // The same limits, met by a literal while parsing.
        EvalAltResult::ErrorParsing(rhai::ParseErrorType::LiteralTooLarge(what, max), _) => {
            format!("{what} exceeds the sandbox's limit ({max}); if it is real, raise it with {} N", size_flag(what))
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

/// The option that raises the size limit an error message names.
fn size_flag(what: &str) -> &'static str {
    match what {
        w if w.contains("rray") || w.contains("BLOB") => "--max-array-size",
        w if w.contains("tring") => "--max-string-size",
        w if w.contains("ap") => "--max-map-size",
        _ => "--max-array-size, --max-string-size or --max-map-size",
    }
}

/// A full report: `error: …`, the location with a caret, then the call chain.
pub fn render(e: &EvalAltResult, sources: &Sources<'_>) -> String {
    let (inner, chain) = unwind(e);
    let mut out = format!("error: {}\n", terminal_text::lines(&message(inner)));
    // The innermost position belongs to the innermost call's source (a stdlib module or the
    // script); the outer calls are in the script that made them.
    let inner_source = chain.last().map(|(_, s, _)| s.clone()).unwrap_or_default();
    let mut pos = inner.position();
    // Rhai reports a missing separator or terminator where the next token starts, often on
    // the next line; the caret belongs right after the code that lacks it.
    if let EvalAltResult::ErrorParsing(rhai::ParseErrorType::MissingToken(..), _) = inner {
        if let Some((_, text)) = sources.text(&inner_source) {
            pos = after_previous_code(text, pos);
        }
    }
    out.push_str(&snippet(sources, &inner_source, pos));
    let text = sources.text(&inner_source).map_or("", |(_, text)| text);
    if let Some(hint) = (sources.hint)(inner, text) {
        out.push_str(&format!("  = help: {}\n", terminal_text::lines(&hint)));
    }
    for (k, (name, _, pos)) in chain.iter().enumerate().rev() {
        let caller_src = if k == 0 { String::new() } else { chain[k - 1].1.clone() };
        out.push_str(&format!("  = in call to `{}`\n", terminal_text::one_line(name)));
        out.push_str(&snippet(sources, &caller_src, *pos));
    }
    out
}

/// The position just after the last non-blank character before `pos` in `text`, when
/// that is on an earlier line (else `pos`).
fn after_previous_code(text: &str, pos: Position) -> Position {
    let (Some(line), Some(col)) = (pos.line(), pos.position()) else { return pos };
    let lines: Vec<&str> = text.lines().collect();
    let before_on_line = lines.get(line - 1).map_or("", |l| {
        let end = l.char_indices().nth(col.saturating_sub(1)).map_or(l.len(), |(i, _)| i);
        &l[..end]
    });
    if !before_on_line.trim().is_empty() {
        return pos;
    }
    (0..line.saturating_sub(1))
        .rev()
        .find(|&k| !lines[k].trim().is_empty())
        .map_or(pos, |k| Position::new(k as u16 + 1, lines[k].trim_end().chars().count() as u16 + 1))
}

fn snippet(sources: &Sources<'_>, source: &str, pos: Position) -> String {
    let (Some(line), Some((path, text))) = (pos.line(), sources.text(source)) else {
        return String::new();
    };
    let col = pos.position().unwrap_or(1);
    let full = text.lines().nth(line - 1).unwrap_or("");
    // A generated one-line script may be huge: show the part around the column.
    let (code, caret) = window(full, col.saturating_sub(1), SNIPPET_WIDTH);
    let w = line.to_string().len();
    let pad = " ".repeat(w);
    // Keep the caret under the character even when the line has tabs, or characters shown
    // as escapes (several columns each).
    let mut lead = String::new();
    for c in code.chars().take(caret) {
        match c {
            '\t' => lead.push('\t'),
            c => {
                lead.extend(std::iter::repeat_n(' ', terminal_text::lines(c.encode_utf8(&mut [0; 4])).chars().count()))
            }
        }
    }
    let (path, code) = (terminal_text::one_line(&path), terminal_text::lines(&code));
    format!("{pad} ┌─ {path}:{line}:{col}\n{pad} │\n{line} │ {code}\n{pad} │ {lead}^\n")
}

/// The most characters of a source line a report shows.
const SNIPPET_WIDTH: usize = 160;

/// At most `width` characters of `line` around character `at`, with `…` where it was cut,
/// and where `at` falls in what is shown.
fn window(line: &str, at: usize, width: usize) -> (String, usize) {
    let n = line.chars().count();
    if n <= width {
        return (line.to_string(), at);
    }
    let start = at.saturating_sub(width / 2).min(n - width);
    let mut shown: String = line.chars().skip(start).take(width).collect();
    let mut caret = at - start;
    if start > 0 {
        shown.insert(0, '…');
        caret += 1;
    }
    if start + width < n {
        shown.push('…');
    }
    (shown, caret)
}

#[cfg(test)]
mod window_tests {
    use super::window;

    #[test]
    fn a_missing_terminator_is_placed_after_the_code_that_lacks_it() {
        use rhai::Position;
        let text = "let a = 1\n\nlet b = 2;";
        assert_eq!(super::after_previous_code(text, Position::new(3, 1)), Position::new(1, 10));
        // On the same line as code before it, the position stands.
        assert_eq!(super::after_previous_code("f(1 2)", Position::new(1, 5)), Position::new(1, 5));
    }

    #[test]
    fn a_long_line_is_cut_around_the_column_with_the_caret_kept_on_it() {
        let line = format!("{}X{}", "a".repeat(1000), "b".repeat(1000));
        let (shown, caret) = window(&line, 1000, 160);
        assert!(shown.chars().count() <= 162, "{}", shown.len());
        assert_eq!(shown.chars().nth(caret), Some('X'));
        assert!(shown.starts_with('…') && shown.ends_with('…'));
        assert_eq!(window("short", 2, 160), ("short".to_string(), 2));
    }
}
