//! Reads a crate's module graph from its source files, for the dependency tests of the engine
//! (`module_deps.rs`) and of the host (`tests/module_layers.rs`, which includes this file).
//!
//! A reference is a path in code (comments and string literals are skipped): `crate::a::…`
//! inline, `use crate::a::b`, `use crate::{a, b::c}`, `super::…` that climbs out of its
//! module (`super::super::x` from `a/b.rs` is `crate::x`; an inline `mod tests {…}` counts as
//! a level), and, where the caller names the library crate, `<library>::a::…`; in a crate's
//! root (`lib.rs`, `main.rs`) also a bare `a::…`. The graph's nodes and what each reference
//! joins are the caller's; circles are found here (Tarjan), with one circle through each and
//! the line that makes each of its steps.

#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// An edge between two modules, with the lines that make it: `file:line: code`.
pub type Graph = BTreeMap<(String, String), Vec<String>>;

/// The source files under `dir` as (path relative to it, with `/` separators; text).
pub fn sources(dir: &Path) -> Vec<(String, String)> {
    let files = rust_files(dir);
    assert!(files.len() > 20, "found only {} source files under {}", files.len(), dir.display());
    files
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(dir).unwrap().components();
            let rel: Vec<String> = rel.map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
            (rel.join("/"), fs::read_to_string(&p).unwrap())
        })
        .collect()
}

/// Every `.rs` file under `dir`, sorted.
pub fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in fs::read_dir(&d).unwrap_or_else(|e| panic!("reading {}: {e}", d.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "rs") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// `text` with its comments and the insides of its string and character literals blanked
/// out; line breaks stay where they were, so line numbers still hold.
pub fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(k).copied().unwrap_or('\0');
        if c[i] == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if c[i] == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if c[i] == 'r'
            && (at(i + 1) == '"' || at(i + 1) == '#')
            && (!ident_char(at(i.wrapping_sub(1)))
                || (at(i.wrapping_sub(1)) == 'b' && !ident_char(at(i.wrapping_sub(2)))))
        {
            // A raw string r"…" or r#"…"#: it ends at a quote and as many hashes.
            let mut j = i + 1;
            while at(j) == '#' {
                j += 1;
            }
            if at(j) != '"' {
                out.push(c[i]);
                i += 1;
                continue;
            }
            let hashes = j - i - 1;
            let close: Vec<char> = std::iter::once('"').chain(std::iter::repeat_n('#', hashes)).collect();
            out.push('"');
            for _ in i + 1..=j {
                out.push(' ');
            }
            i = j + 1;
            while i < c.len() && !c[i..].starts_with(&close) {
                blank(&mut out, c[i]);
                i += 1;
            }
            out.push('"');
            for _ in 0..hashes {
                out.push(' ');
            }
            i += close.len();
        } else if c[i] == '"' {
            out.push('"');
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    blank(&mut out, c[i]);
                    i += 1;
                }
                if i < c.len() {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
            out.push('"');
            i += 1;
        } else if c[i] == '\'' && (at(i + 1) == '\\' || (at(i + 2) == '\'' && at(i + 1) != '\'')) {
            // A character literal ('x', '\n', '\u{7f}'), not a lifetime ('a).
            out.push('\'');
            i += 1;
            while i < c.len() && c[i] != '\'' {
                if c[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                out.push(' ');
                i += 1;
            }
            out.push('\'');
            i += 1;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

pub fn ident_char(ch: char) -> bool {
    ch.is_alphanumeric() || ch == '_'
}

/// A token of code: an identifier, `::`, or one other character; with its line (from 1).
pub struct Token {
    pub text: String,
    pub line: usize,
}

pub fn tokens(code: &str) -> Vec<Token> {
    let mut out = Vec::new();
    for (k, line) in code.lines().enumerate() {
        let c: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < c.len() {
            if ident_char(c[i]) {
                let start = i;
                while i < c.len() && ident_char(c[i]) {
                    i += 1;
                }
                out.push(Token { text: c[start..i].iter().collect(), line: k + 1 });
            } else if c[i] == ':' && c.get(i + 1) == Some(&':') {
                out.push(Token { text: "::".into(), line: k + 1 });
                i += 2;
            } else {
                if !c[i].is_whitespace() {
                    out.push(Token { text: c[i].to_string(), line: k + 1 });
                }
                i += 1;
            }
        }
    }
    out
}

/// The module path a file defines: `api/run_points.rs` is `api::run_points`, `api/mod.rs` is `api`,
/// `lib.rs` and `main.rs` are their crate's root.
pub fn module_path(file: &str) -> Vec<String> {
    let mut parts: Vec<String> = file.trim_end_matches(".rs").split('/').map(String::from).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    parts
}

/// A reference from a file's line to a module path (crate-relative, first segment first).
pub struct Reference {
    pub line: usize,
    pub path: Vec<String>,
    /// Through the library crate's name (`matdem_rs::`): the library, from the binary.
    pub library: bool,
}

/// The paths `file`'s code names outside itself: each `crate::`, `<library>::` or `super::`
/// path, resolved from the crate root, up to its last segment (an item or a module: the caller
/// tells them apart) or a `{…}` group, which gives one path per item (the item's own first
/// segments).
pub fn references(file: &str, text: &str, library: &str) -> Vec<Reference> {
    let t = tokens(&code_only(text));
    let here = module_path(file);
    let mut out = Vec::new();
    // Inline modules (`mod tests { … }`): their names, and the brace depth they opened at.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0;
    let text_at = |k: usize| t.get(k).map(|x| x.text.as_str()).unwrap_or("");
    let mut i = 0;
    while i < t.len() {
        match t[i].text.as_str() {
            "{" => depth += 1,
            "}" => {
                depth -= 1;
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
            }
            "mod" if text_at(i + 2) == "{" => {
                inline.push((text_at(i + 1).to_string(), depth));
            }
            _ => {}
        }
        let head = t[i].text.as_str();
        let starts_path = text_at(i + 1) == "::" && text_at(i.wrapping_sub(1)) != "::";
        let base: Option<(Vec<String>, bool)> = match head {
            "crate" if starts_path => Some((Vec::new(), false)),
            h if h == library && starts_path => Some((Vec::new(), true)),
            "super" if starts_path => {
                let mut at: Vec<String> = here.iter().cloned().chain(inline.iter().map(|(n, _)| n.clone())).collect();
                let mut j = i;
                while text_at(j) == "super" && text_at(j + 1) == "::" {
                    at.pop();
                    j += 2;
                }
                Some((at, false))
            }
            _ => None,
        };
        let Some((base, library)) = base else {
            // In a crate's root, its modules are in scope by their bare names (`api::register`).
            let root = here.is_empty() && inline.is_empty();
            if root && starts_path && ident_char(head.chars().next().unwrap_or(' ')) && head != "self" {
                out.push(Reference { line: t[i].line, path: vec![head.to_string()], library: false });
            }
            i += 1;
            continue;
        };
        // Past the head (and any further `super::`) to what the path names.
        let mut j = i + 2;
        while text_at(j) == "super" && text_at(j + 1) == "::" {
            j += 2;
        }
        let line = t[i].line;
        // The segments `a::b::c` from token k on, up to a group, a glob or the path's end.
        let chain = |mut k: usize| {
            let mut out = Vec::new();
            while ident_char(text_at(k).chars().next().unwrap_or(' ')) {
                out.push(text_at(k).to_string());
                if text_at(k + 1) != "::" {
                    break;
                }
                k += 2;
            }
            out
        };
        let mut named = Vec::new();
        if text_at(j) == "{" {
            // A group: the first token of each item at the group's own depth.
            let mut level = 0;
            let mut item_start = true;
            let mut k = j;
            while k < t.len() {
                match text_at(k) {
                    "{" => {
                        level += 1;
                        if level == 1 {
                            item_start = true;
                            k += 1;
                            continue;
                        }
                    }
                    "}" => {
                        level -= 1;
                        if level == 0 {
                            break;
                        }
                    }
                    "," if level == 1 => {
                        item_start = true;
                        k += 1;
                        continue;
                    }
                    _ => {}
                }
                if item_start && level == 1 {
                    named.push(chain(k));
                }
                item_start = false;
                k += 1;
            }
        } else {
            named.push(chain(j));
        }
        for names in named {
            let mut path = base.clone();
            path.extend(names.into_iter().filter(|n| n != "self"));
            out.push(Reference { line, path, library });
        }
        i = j;
    }
    out
}

/// The strongly connected components of more than one node (Tarjan's algorithm), each sorted.
pub fn circles(nodes: &BTreeSet<String>, graph: &Graph) -> Vec<Vec<String>> {
    struct State<'a> {
        graph: &'a Graph,
        index: BTreeMap<String, usize>,
        low: BTreeMap<String, usize>,
        stack: Vec<String>,
        on_stack: BTreeSet<String>,
        out: Vec<Vec<String>>,
    }
    fn visit(s: &mut State, v: &str) {
        let n = s.index.len();
        s.index.insert(v.into(), n);
        s.low.insert(v.into(), n);
        s.stack.push(v.into());
        s.on_stack.insert(v.into());
        let next: Vec<String> = s.graph.keys().filter(|(a, _)| a == v).map(|(_, b)| b.clone()).collect();
        for w in next {
            if !s.index.contains_key(&w) {
                visit(s, &w);
                let l = s.low[v].min(s.low[&w]);
                s.low.insert(v.into(), l);
            } else if s.on_stack.contains(&w) {
                let l = s.low[v].min(s.index[&w]);
                s.low.insert(v.into(), l);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on_stack.remove(&w);
                let done = w == v;
                component.push(w);
                if done {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in nodes {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out.sort();
    s.out
}

/// One circle through `start` inside `component` (a shortest one, by breadth-first search).
pub fn a_circle_through(start: &str, component: &[String], graph: &Graph) -> Vec<String> {
    let inside = |x: &String| component.contains(x);
    let mut came_from: BTreeMap<String, String> = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([start.to_string()]);
    while let Some(v) = queue.pop_front() {
        for (_, w) in graph.keys().filter(|(a, b)| *a == v && inside(b)) {
            if w == start {
                let mut path = vec![v.clone()];
                while let Some(p) = came_from.get(path.last().unwrap()) {
                    path.push(p.clone());
                }
                path.reverse();
                path.push(start.to_string());
                return path;
            }
            if !came_from.contains_key(w) && w != start {
                came_from.insert(w.clone(), v.clone());
                queue.push_back(w.clone());
            }
        }
    }
    unreachable!("{start} is on no circle in {component:?}")
}

/// A circle, hop by hop, each hop with the first line that makes it.
pub fn describe_circle(circle: &[String], graph: &Graph) -> String {
    let mut out = circle.join(" → ");
    for hop in circle.windows(2) {
        let lines = &graph[&(hop[0].clone(), hop[1].clone())];
        out.push_str(&format!("\n    {} → {}: {}", hop[0], hop[1], lines[0]));
        if lines.len() > 1 {
            out.push_str(&format!(" (and {} more)", lines.len() - 1));
        }
    }
    out
}
