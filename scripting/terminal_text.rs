//! Text that came from a script, a package manifest, a sweep folder or a CSV, on its way to a
//! terminal: control characters are shown as escapes (`\x1b`, `\u{9b}`, `\u{202e}`) instead
//! of being obeyed, so such text cannot write the clipboard (OSC 52), clear the screen, move
//! the cursor over earlier lines or reorder what is shown (bidi overrides). Files keep the
//! raw text; only what is printed goes through here.

use std::borrow::Cow;
use std::fmt::Write as _;

/// `text` for one line of output (a value, a name, an error in a list): every control
/// character escaped, newlines and tabs included, so it cannot start a fake line.
pub fn one_line(text: &str) -> Cow<'_, str> {
    render(text, false)
}

/// `text` of several lines (what a script prints, an error report): newlines (also `\r\n`)
/// and tabs kept, every other control character escaped.
pub fn lines(text: &str) -> Cow<'_, str> {
    render(text, true)
}

/// Whether a terminal would act on `c` rather than show it: C0 and C1 controls, DEL, and
/// the bidi embeddings, overrides and isolates (U+202A–U+202E, U+2066–U+2069).
fn obeyed(c: char) -> bool {
    matches!(c, '\u{0}'..='\u{1f}' | '\u{7f}'..='\u{9f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

fn render(text: &str, layout: bool) -> Cow<'_, str> {
    let kept = |c: char, next: Option<char>| {
        !obeyed(c) || (layout && (c == '\n' || c == '\t' || (c == '\r' && next == Some('\n'))))
    };
    let mut chars = text.chars().peekable();
    let mut clean = true;
    while let Some(c) = chars.next() {
        if !kept(c, chars.peek().copied()) {
            clean = false;
            break;
        }
    }
    if clean {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if kept(c, chars.peek().copied()) {
            out.push(c);
            continue;
        }
        match c {
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if (c as u32) < 0x80 => {
                let _ = write!(out, "\\x{:02x}", c as u32);
            }
            c => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
        }
    }
    Cow::Owned(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_and_bidi_overrides_are_shown_and_plain_text_is_untouched() {
        let hostile = "\u{1b}]52;c;aGk=\u{7}\u{1b}[2J\u{9b}1m\u{202e}evil\u{2066}\u{7f}";
        assert_eq!(one_line(hostile), "\\x1b]52;c;aGk=\\x07\\x1b[2J\\u{9b}1m\\u{202e}evil\\u{2066}\\x7f");
        assert!(matches!(one_line("plain — ü ∑ 漢"), Cow::Borrowed(_)));
        assert_eq!(one_line("a\nb\tc\r\n"), "a\\nb\\tc\\r\\n");
        assert_eq!(lines("a\nb\tc\r\nd\re"), "a\nb\tc\r\nd\\re");
        // Escaping twice changes nothing: what comes out holds no control character.
        assert_eq!(lines(&lines(hostile)), lines(hostile));
    }
}
