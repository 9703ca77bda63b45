//! The host's dependency directions, read from its source files (`scripting/`): its
//! top-level modules form no circle, and each names only modules of its own layer or of a
//! layer below it, per [`LAYERS`].
//!
//! A reference is a path in code (comments and string literals are skipped): `crate::a::…`
//! inline, `use crate::a::b`, `use crate::{a, b::c}`, `super::…` that climbs out of its
//! top-level module (`super::super::x` from `a/b.rs` is `crate::x`; an inline `mod tests {…}`
//! counts as a level), and in the binary's files (`main.rs`, `cli.rs`, `commands/`) also
//! `matdem_rs::a::…`; in a crate's root (`lib.rs`, `main.rs`) also a bare `a::…`. A path to
//! an item of `lib.rs` itself (`crate::new_engine`) names the crate root, node `lib`; the
//! binary's root is node `main`.
//!
//! A failure names the file and the line of each offending reference.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The host's layers, lowest first. A module may name modules of its own layer and of the
/// layers before it, never of a layer after it; no modules name each other in a circle, in a
/// layer or across layers (`the_hosts_modules_form_no_circle`). Every top-level module of
/// `lib.rs` and of the binary (`main.rs`) is listed here once: a new module needs its line.
///
/// The script API sits above the outputs and the workflows because it is their binding:
/// `show` draws with `plot`, `d.movie_every` records a `movie`, `export_*` write snapshots,
/// the calibration functions call `calibration`, `run_points` plans and runs a `sweep`, and a
/// run's parameters are a `package`'s. What those layers took from the script API went down:
/// the metrics file's format (`metrics`), atomic writes (`atomic`), a picture's particle
/// fields (`picture_fields`); the journal's file and types stay in `resume` while turning a
/// script's values into them and writing and restoring a resume point moved into the API
/// (`api::resume_point`), as did deciding `--backend auto` (`api::auto_backend`).
const LAYERS: &[(&str, &[&str])] = &[
    // What everything stands on: atomic writes and the output folder's lock, the sandbox (what
    // a script may read and write, its limits, the names the host keeps), the memory budget,
    // the run record, the resume journal's files, the metrics file, the run's backend, Ctrl-C,
    // error rendering, terminal-safe text and the embedded standard library.
    (
        "core",
        &[
            "atomic",
            "memory",
            "metrics",
            "out_lock",
            "report",
            "resume",
            "run_backend",
            "run_record",
            "sandbox",
            "stdlib",
            "stop",
            "terminal_text",
        ],
    ),
    // What a run leaves for people to look at: figures, particle pictures and movies, VTK
    // snapshots, the report page.
    ("outputs", &["movie", "picture_fields", "plot", "report_page", "snapshot"]),
    // Many runs, or runs of a package: calibration designs and fits, packages, sweeps and
    // the studies built on them.
    ("workflows", &["calibration", "package", "study", "sweep"]),
    // The script API (`api`) and the Rhai engine it is registered into (`lib`: `new_engine`).
    ("script API", &["api", "lib"]),
    // What a person starts: a script run, the REPL, the benchmark, the command line.
    ("front ends", &["bench", "cli", "commands", "main", "repl", "run"]),
];

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
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

/// The host's source files as (path relative to `scripting/`, with `/` separators; text).
fn sources() -> Vec<(String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripting");
    let files = rust_files(&src);
    assert!(files.len() > 20, "found only {} source files under {}", files.len(), src.display());
    files
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(&src).unwrap().components();
            let rel: Vec<String> = rel.map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
            (rel.join("/"), fs::read_to_string(&p).unwrap())
        })
        .collect()
}

/// `text` with its comments and the insides of its string and character literals blanked
/// out; line breaks stay where they were, so line numbers still hold.
fn code_only(text: &str) -> String {
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

fn ident_char(ch: char) -> bool {
    ch.is_alphanumeric() || ch == '_'
}

/// A token of code: an identifier, `::`, or one other character; with its line (from 1).
struct Token {
    text: String,
    line: usize,
}

fn tokens(code: &str) -> Vec<Token> {
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

/// The module path a file defines: `api/runs.rs` is `api::runs`, `api/mod.rs` is `api`,
/// `lib.rs` and `main.rs` are their crate's root.
fn module_path(file: &str) -> Vec<String> {
    let mut parts: Vec<String> = file.trim_end_matches(".rs").split('/').map(String::from).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    parts
}

/// A reference from a file's line to a module path (crate-relative, first segment first).
struct Reference {
    line: usize,
    path: Vec<String>,
    /// Through `matdem_rs::`: the library, from the binary.
    library: bool,
}

/// The paths `file`'s code names outside itself: each `crate::`, `matdem_rs::` or `super::`
/// path's first named segment, resolved from the crate root; a `{…}` group gives one path
/// per item.
fn references(file: &str, text: &str) -> Vec<Reference> {
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
            "matdem_rs" if starts_path => Some((Vec::new(), true)),
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
                    named.push(text_at(k).to_string());
                }
                item_start = false;
                k += 1;
            }
        } else {
            named.push(text_at(j).to_string());
        }
        for name in named {
            let mut path = base.clone();
            if name != "self" && ident_char(name.chars().next().unwrap_or(' ')) {
                path.push(name);
            }
            out.push(Reference { line, path, library });
        }
        i = j;
    }
    out
}

/// The top-level modules each crate declares in its root (`mod x;`, `pub mod x;`).
fn declared(root: &str) -> Vec<String> {
    let t = tokens(&code_only(root));
    (0..t.len())
        .filter(|&k| t[k].text == "mod" && t.get(k + 2).is_some_and(|x| x.text == ";"))
        .map(|k| t[k + 1].text.clone())
        .collect()
}

/// An edge between top-level modules, with the lines that make it: `file:line: code`.
type Graph = BTreeMap<(String, String), Vec<String>>;

/// The host's module graph, from the sources given as (path under `scripting/`, text).
/// Nodes are the library's top-level modules, its root `lib`, the binary's top-level
/// modules and its root `main`.
fn graph_of(files: &[(String, String)]) -> (BTreeSet<String>, Graph) {
    let text_of = |name: &str| &files.iter().find(|(p, _)| p == name).unwrap_or_else(|| panic!("no {name}")).1;
    let library: BTreeSet<String> = declared(text_of("lib.rs")).into_iter().collect();
    let binary: BTreeSet<String> = declared(text_of("main.rs")).into_iter().collect();
    let both: Vec<_> = library.intersection(&binary).collect();
    assert!(both.is_empty(), "modules of both the library and the binary: {both:?}");
    let mut nodes: BTreeSet<String> = library.union(&binary).cloned().collect();
    nodes.insert("lib".into());
    nodes.insert("main".into());
    let mut graph = Graph::new();
    for (file, text) in files {
        let here = module_path(file);
        let in_binary = match here.first() {
            Some(top) => binary.contains(top),
            None => file == "main.rs",
        };
        let from = match here.first() {
            Some(top) => top.clone(),
            None if in_binary => "main".into(),
            None => "lib".into(),
        };
        assert!(nodes.contains(&from), "{file} belongs to no module of lib.rs or main.rs");
        let lines: Vec<&str> = text.lines().collect();
        for r in references(file, text) {
            let (root, modules) = if r.library || !in_binary { ("lib", &library) } else { ("main", &binary) };
            let to = match r.path.first() {
                Some(top) if modules.contains(top) => top.clone(),
                _ => root.to_string(),
            };
            if to != from {
                let evidence = format!("scripting/{file}:{}: {}", r.line, lines[r.line - 1].trim());
                let e = graph.entry((from.clone(), to)).or_default();
                if !e.contains(&evidence) {
                    e.push(evidence);
                }
            }
        }
    }
    (nodes, graph)
}

/// The strongly connected components of more than one node (Tarjan's algorithm), each sorted.
fn circles(nodes: &BTreeSet<String>, graph: &Graph) -> Vec<Vec<String>> {
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
fn a_circle_through(start: &str, component: &[String], graph: &Graph) -> Vec<String> {
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
fn describe_circle(circle: &[String], graph: &Graph) -> String {
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

/// The layer (index in [`LAYERS`]) of each module.
fn layer_of() -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    for (k, (_, modules)) in LAYERS.iter().enumerate() {
        for m in *modules {
            assert!(out.insert(m.to_string(), k).is_none(), "{m} is in LAYERS twice");
        }
    }
    out
}

#[test]
fn the_hosts_modules_form_no_circle() {
    let (nodes, graph) = graph_of(&sources());
    assert!(nodes.len() > 20 && graph.len() > 50, "the host's modules were not read: {nodes:?}");
    let found: Vec<String> = circles(&nodes, &graph)
        .iter()
        .map(|c| format!("{{{}}}, e.g. {}", c.join(", "), describe_circle(&a_circle_through(&c[0], c, &graph), &graph)))
        .collect();
    assert!(
        found.is_empty(),
        "the host's top-level modules name each other in a circle (each group below names itself \
         through the others; one circle through it, with the line that makes each step):\n{}",
        found.join("\n")
    );
}

#[test]
fn each_host_layer_names_only_layers_below_it() {
    let (nodes, graph) = graph_of(&sources());
    let layer = layer_of();
    let unplaced: Vec<_> = nodes.iter().filter(|n| !layer.contains_key(*n)).collect();
    assert!(unplaced.is_empty(), "modules in no layer of LAYERS (add each to one): {unplaced:?}");
    let stale: Vec<_> = layer.keys().filter(|m| !nodes.contains(*m)).collect();
    assert!(stale.is_empty(), "LAYERS lists modules the host does not have: {stale:?}");
    let mut found = Vec::new();
    for ((from, to), lines) in &graph {
        if layer[to] > layer[from] {
            let (below, above) = (LAYERS[layer[from]].0, LAYERS[layer[to]].0);
            found.push(format!("{from} ({below}) names {to} ({above}):\n    {}", lines.join("\n    ")));
        }
    }
    assert!(found.is_empty(), "a lower layer names a higher one:\n{}", found.join("\n"));
}

/// The reader itself, on made-up files: each form of path it must see, and what it must not
/// take for one.
#[test]
fn the_layer_reader_sees_each_form_of_path() {
    let files = |extra: &[(&str, &str)]| -> Vec<(String, String)> {
        let mut v = vec![
            (
                "lib.rs".to_string(),
                "pub mod a; pub mod b; pub mod c; pub mod d; pub mod e;\nuse e::Thing;\npub fn f() {}".to_string(),
            ),
            ("main.rs".to_string(), "mod cli;".to_string()),
        ];
        v.extend(extra.iter().map(|(p, t)| (p.to_string(), t.to_string())));
        v
    };
    let (_, g) = graph_of(&files(&[
        ("a/mod.rs", "mod x;\nuse crate::{b, c::Thing};\n"),
        ("a/x.rs", "fn f() { super::super::d::g(); }\n"),
        ("b.rs", "// crate::e::h in a comment\nfn f() { let s = \"crate::e::h\"; let c = '{'; crate::f(); }\n"),
        ("c.rs", "#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::e;\n}\n"),
        ("cli.rs", "use matdem_rs::a::Host;\nuse crate::main_helper;\n"),
    ]));
    let edges: Vec<String> = g.iter().map(|((a, b), l)| format!("{a}->{b} {}", l[0])).collect();
    assert_eq!(
        edges,
        [
            "a->b scripting/a/mod.rs:2: use crate::{b, c::Thing};",
            "a->c scripting/a/mod.rs:2: use crate::{b, c::Thing};",
            "a->d scripting/a/x.rs:1: fn f() { super::super::d::g(); }",
            "b->lib scripting/b.rs:2: fn f() { let s = \"crate::e::h\"; let c = '{'; crate::f(); }",
            "c->e scripting/c.rs:4: use super::super::e;",
            "cli->a scripting/cli.rs:1: use matdem_rs::a::Host;",
            "cli->main scripting/cli.rs:2: use crate::main_helper;",
            "lib->e scripting/lib.rs:2: use e::Thing;",
        ]
    );
    let nodes: BTreeSet<String> = ["a", "b", "c", "d", "e", "lib", "cli", "main"].map(String::from).into();
    assert!(circles(&nodes, &g).is_empty());
    let (_, g) =
        graph_of(&files(&[("a.rs", "use crate::b;"), ("b.rs", "use crate::c::x;"), ("c.rs", "use crate::a;")]));
    let found = circles(&nodes, &g);
    assert_eq!(found, [["a", "b", "c"].map(String::from)]);
    assert!(describe_circle(&a_circle_through("a", &found[0], &g), &g)
        .starts_with("a → b → c → a\n    a → b: scripting/a.rs:1: use crate::b;"));
}
