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
//! binary's root is node `main`. A path to a `#[macro_export]` macro (`crate::outln`, which
//! Rust puts at the crate root) names the module that defines it (`console`).
//!
//! A failure names the file and the line of each offending reference. The reader of paths
//! and circles is the engine's (`engine/tests/module_graph.rs`), shared by both crates' tests.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use crate::module_graph::{
    self, a_circle_through, circles, code_only, describe_circle, module_path, references, tokens, Graph,
};

/// The host's layers, lowest first. A module may name modules of its own layer and of the
/// layers before it, never of a layer after it; no modules name each other in a circle, in a
/// layer or across layers (`the_hosts_modules_form_no_circle`). Every top-level module of
/// `lib.rs` and of the binary (`main.rs`) is listed here once: a new module needs its line.
///
/// The script API sits above the outputs and the workflows because it is their binding:
/// `show` draws with `plot`, `d.movie_every` records a `movie`, `export_*` write snapshots,
/// the calibration functions call `calibration`, `run_points` plans and runs a `sweep`, and a
/// run's parameters are a `package`'s. What those layers took from the script API went down:
/// the metrics file's format (`metrics`), atomic writes (`atomic_write`), a picture's particle
/// fields (`picture_fields`); the journal's file and types stay in `resume` while turning a
/// script's values into them and writing and restoring a resume point moved into the API
/// (`api::resume_point`), as did deciding `--backend auto` (`api::auto_backend`).
const LAYERS: &[(&str, &[&str])] = &[
    // What everything stands on: atomic writes and the output folder's lock, the sandbox (what
    // a script may read and write, its limits, the names the host keeps), the memory budget,
    // the run record, the resume journal's files, the metrics file, the run's backend, Ctrl-C,
    // error rendering, the terminal's streams (console) and terminal-safe text, and the
    // embedded standard library.
    (
        "core",
        &[
            "atomic_write",
            "console",
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
    ("front ends", &["bench", "cli", "commands", "main", "repl", "script_run"]),
];

/// The host's source files as (path relative to `scripting/`, with `/` separators; text).
fn sources() -> Vec<(String, String)> {
    module_graph::sources(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scripting"))
}

/// The top-level modules each crate declares in its root (`mod x;`, `pub mod x;`).
fn declared(root: &str) -> Vec<String> {
    let t = tokens(&code_only(root));
    (0..t.len())
        .filter(|&k| t[k].text == "mod" && t.get(k + 2).is_some_and(|x| x.text == ";"))
        .map(|k| t[k + 1].text.clone())
        .collect()
}

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
    let exported = exported_macros(files);
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
        for r in references(file, text, "matdem_rs") {
            let (root, modules) = if r.library || !in_binary { ("lib", &library) } else { ("main", &binary) };
            let to = match r.path.first() {
                Some(top) if modules.contains(top) => top.clone(),
                Some(name) if root == "lib" && exported.contains_key(name) => exported[name].clone(),
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

/// The library's `#[macro_export]` macros and the top-level module that defines each.
fn exported_macros(files: &[(String, String)]) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for (file, text) in files {
        let code = code_only(text);
        for piece in code.split("#[macro_export]").skip(1) {
            let name = piece
                .trim_start()
                .strip_prefix("macro_rules!")
                .map(|rest| rest.trim_start().chars().take_while(|&c| module_graph::ident_char(c)).collect::<String>());
            let top = module_path(file).first().cloned().unwrap_or_else(|| "lib".into());
            if let Some(name) = name.filter(|n| !n.is_empty()) {
                out.insert(name, top);
            }
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
        ("cli.rs", "use matdem_rs::a::Host;\nuse crate::main_helper;\nuse matdem_rs::say;\n"),
        ("d.rs", "#[macro_export]\nmacro_rules! say { () => {} }\n"),
        ("e.rs", "use crate::say;\n"),
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
            "cli->d scripting/cli.rs:3: use matdem_rs::say;",
            "cli->main scripting/cli.rs:2: use crate::main_helper;",
            "e->d scripting/e.rs:1: use crate::say;",
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
