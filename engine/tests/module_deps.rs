//! The engine's dependency directions, read from its source files:
//!
//! - only the CPU backend names the CPU backend: no file outside `src/backend/cpu/` and the
//!   effects' CPU passes (`effects/<name>/cpu.rs` or `cpu/`) mentions `backend::cpu` (the
//!   model, the neighbour rows, the run loop and the GPU backend depend on the engine's
//!   modules, not on one backend; `backend/mod.rs` names its two backends as `cpu::…` and
//!   `gpu::…`);
//! - the GPU side (the GPU backend and the effects' GPU kernels) never reaches into the CPU
//!   side, nor the CPU side into the GPU's;
//! - every stage of the registry has its files, its parity test and its checkpoint section;
//! - the engine never imports the host: no `rhai`, `plotters`, `clap` or `matdem_rs` path in
//!   its source and none of them among its Cargo dependencies;
//! - no modules name each other in a circle, at any folder's level (`engine_graph`).
//!
//! A failure names the file and the line.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

use matdem_engine::plan::{Entry, REGISTRY};
use matdem_engine::plan::{Role, Stage};

use crate::module_graph::{self, a_circle_through, circles, describe_circle, module_path, references, Graph};

/// The engine's source files as (path relative to `src/`, with `/` separators; text).
fn sources() -> Vec<(String, String)> {
    module_graph::sources(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

/// `file:line: text` for each line of the files `select` picks that contains `needle`.
fn mentions(select: impl Fn(&str) -> bool, needle: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (path, text) in sources().iter().filter(|(p, _)| select(p)) {
        for (k, line) in text.lines().enumerate() {
            if line.contains(needle) {
                out.push(format!("src/{path}:{}: {}", k + 1, line.trim()));
            }
        }
    }
    out
}

/// Whether the source file at `path` (relative to `src/`) is on the `side` ("cpu" or "gpu"):
/// in the backend's folder, or an effect's pass for it (`effects/<name>/<side>.rs` or a file
/// of `effects/<name>/<side>/`).
fn on_side(path: &str, side: &str) -> bool {
    if path.starts_with(&format!("backend/{side}/")) {
        return true;
    }
    let parts: Vec<&str> = path.split('/').collect();
    parts.len() >= 3 && parts[0] == "effects" && (parts[2] == format!("{side}.rs") || parts[2] == side)
}

#[test]
fn only_the_cpu_side_names_the_cpu_backend() {
    let found = mentions(|p| !on_side(p, "cpu"), "backend::cpu");
    assert!(
        found.is_empty(),
        "outside backend/cpu/ and the effects' CPU passes, use the engine's modules (neighbours, plan, \
         status, simulation) or the Backend trait, not the CPU backend:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_cpu_and_gpu_sides_do_not_reach_into_each_other() {
    let gpu = mentions(|p| on_side(p, "gpu"), "cpu::");
    assert!(gpu.is_empty(), "the GPU side names the CPU side:\n{}", gpu.join("\n"));
    let cpu = mentions(|p| on_side(p, "cpu"), "gpu::");
    assert!(cpu.is_empty(), "the CPU side names the GPU side:\n{}", cpu.join("\n"));
}

#[test]
fn an_effects_cpu_and_gpu_passes_are_told_apart() {
    assert!(on_side("effects/moisture/cpu.rs", "cpu") && on_side("effects/pore_flow/cpu/heat.rs", "cpu"));
    assert!(on_side("effects/moisture/gpu.rs", "gpu") && !on_side("effects/moisture/gpu.rs", "cpu"));
    assert!(!on_side("effects/moisture/mod.rs", "cpu") && !on_side("effects/moisture/lanes.rs", "gpu"));
    assert!(on_side("backend/cpu/fused.rs", "cpu") && !on_side("plan/mod.rs", "cpu"));
}

/// The host's crates, as paths in Rust source and as Cargo dependency names.
const HOST: [(&str, &str); 4] =
    [("rhai", "rhai"), ("plotters", "plotters"), ("clap", "clap"), ("matdem_rs", "matdem-rs")];

#[test]
fn the_engine_never_imports_the_host() {
    let mut found = Vec::new();
    for (krate, _) in HOST {
        for needle in [format!("{krate}::"), format!("use {krate}"), format!("extern crate {krate}")] {
            found.extend(mentions(|_| true, &needle));
        }
    }
    found.sort();
    found.dedup();
    assert!(found.is_empty(), "the engine imports the host:\n{}", found.join("\n"));

    // Every [dependencies]-like table of the engine's manifest ([dev-dependencies],
    // [target.'…'.dependencies] …).
    let manifest = fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml")).unwrap();
    let mut table = String::new();
    let mut deps = Vec::new();
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            table = line.to_string();
        } else if table.ends_with("dependencies]") {
            if let Some((name, _)) = line.split_once('=') {
                let name = name.trim().split('.').next().unwrap().trim_matches('"').to_string();
                if !name.starts_with('#') {
                    deps.push(name);
                }
            }
        }
    }
    assert!(deps.iter().any(|d| d == "rayon"), "the manifest's dependencies were not read: {deps:?}");
    for (_, dep) in HOST {
        assert!(!deps.iter().any(|d| d == dep), "the engine depends on the host's `{dep}`: {deps:?}");
    }
}

/// The first of `candidates` (paths relative to `src/`) that is a file.
fn first_file(src: &Path, candidates: &[String]) -> Option<PathBuf> {
    candidates.iter().map(|p| src.join(p)).find(|p| p.is_file())
}

/// Where a stage's CPU pass and GPU kernel may live: an effect's in its folder
/// (`effects/<name>/cpu.rs` or `cpu/mod.rs`, likewise `gpu`); a core stage's in the backends,
/// the CPU's as `backend/cpu/<name>.rs` or the engine-level `<name>.rs` or `<name>/mod.rs`
/// both backends share (walls, neighbours, guard).
fn pass_candidates(entry: &Entry, side: &str) -> Vec<String> {
    let name = entry.name;
    if entry.effect {
        return vec![format!("effects/{name}/{side}.rs"), format!("effects/{name}/{side}/mod.rs")];
    }
    let mut out = vec![format!("backend/{side}/{name}.rs")];
    if side == "cpu" {
        out.extend([format!("{name}.rs"), format!("{name}/mod.rs")]);
    }
    out
}

#[test]
fn every_registered_stage_has_a_wgsl_file_a_gpu_kernel_and_a_cpu_pass_of_its_name() {
    let engine = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = engine.join("src");
    let mut missing = Vec::new();
    for entry in &REGISTRY {
        let name = entry.name;
        if !engine.join(format!("../shaders/{name}.wgsl")).is_file() {
            missing.push(format!("{name}: no shaders/{name}.wgsl"));
        }
        for side in ["cpu", "gpu"] {
            let candidates = pass_candidates(entry, side);
            if first_file(&src, &candidates).is_none() {
                missing.push(format!("{name}: no {side} pass: none of src/{}", candidates.join(", src/")));
            }
        }
        if entry.effect && !src.join(format!("effects/{name}/mod.rs")).is_file() {
            missing.push(format!("{name}: an effect without its folder src/effects/{name}/mod.rs"));
        }
    }
    assert!(missing.is_empty(), "stages without their files:\n{}", missing.join("\n"));
}

/// The registry's rows name their stages, in `Stage::ALL`'s order, and only an optional
/// stage is an effect with a script switch.
#[test]
fn the_registry_is_the_step_order_and_names_its_effects() {
    let names: Vec<&str> = Stage::ALL.iter().map(|s| s.name()).collect();
    assert_eq!(names, REGISTRY.iter().map(|e| e.name).collect::<Vec<_>>());
    for e in &REGISTRY {
        let optional = !matches!(e.role, Role::Core | Role::Guard);
        assert_eq!(e.effect, optional, "{}: an optional stage, and only one, is an effect", e.name);
        assert_eq!(e.script.is_empty(), !optional, "{}: an effect, and only one, has a script switch", e.name);
        assert_eq!(e.off.is_empty(), !optional, "{}: an effect, and only one, is named when it is off", e.name);
    }
}

/// A row's checkpoint section exists: `Section::<Variant>` a variant of checkpoint.rs's
/// `Section`, `record.<field>` a field of its record, `effects.<name>` the effect's state in the
/// effects' list (`effect_states!`, which a checkpoint carries by the state's name, the effect's).
#[test]
fn every_registered_checkpoint_section_is_in_the_checkpoint() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let text = fs::read_to_string(src.join("checkpoint.rs")).unwrap();
    let effects = fs::read_to_string(src.join("effects/mod.rs")).unwrap();
    let states = &effects[effects.find("effect_states! {").expect("effects/mod.rs lists the effects' states")..];
    let states = &states[..states.find("\n}").unwrap()];
    let section = &text[text.find("enum Section {").expect("checkpoint.rs has `enum Section`")..];
    let section = &section[..section.find("\n}").unwrap()];
    let mut missing = Vec::new();
    for e in REGISTRY.iter().filter(|e| !e.checkpoint.is_empty()) {
        let found = match e.checkpoint.split_once(['.', ':']) {
            Some(("Section", v)) => section.contains(&format!("    {} {{", v.trim_start_matches(':'))),
            Some(("record", field)) => text.contains(&format!("    {field}: ")),
            Some(("effects", name)) => {
                let state = fs::read_to_string(src.join(format!("effects/{name}/state.rs"))).unwrap_or_default();
                name == e.name
                    && states.contains(&format!("    {name}: {name}::state::"))
                    && state.contains(&format!("const NAME: &'static str = \"{name}\";"))
            }
            _ => false,
        };
        if !found {
            missing.push(format!("{}: {}", e.name, e.checkpoint));
        }
    }
    assert!(missing.is_empty(), "registered checkpoint sections not in checkpoint.rs:\n{}", missing.join("\n"));
    assert!(REGISTRY.iter().filter(|e| e.effect).all(|e| !e.checkpoint.is_empty()), "every effect names its section");
}

/// The test files that hold the GPU parity tests of stages tested together; any other stage's
/// are in `tests/<name>.rs` or `tests/<name>_parity.rs`.
const PARITY_FILES: [(&str, &str); 9] = [
    ("walls", "gpu_parity"),
    ("neighbours", "gpu_parity"),
    ("contact_forces", "gpu_parity"),
    ("wall_forces", "gpu_parity"),
    ("integrate", "gpu_parity"),
    ("guard", "gpu_parity"),
    ("heat_ledger", "gpu_energy"),
    ("conduction", "field_parity"),
    ("buoyancy", "field_parity"),
];

#[test]
fn every_stage_has_a_test_that_runs_it_on_the_gpu() {
    let tests = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut missing = Vec::new();
    for stage in Stage::ALL {
        let name = stage.name();
        let listed = PARITY_FILES.iter().find(|(s, _)| *s == name).map(|(_, f)| vec![f.to_string()]);
        let files = listed.unwrap_or_else(|| vec![name.to_string(), format!("{name}_parity")]);
        // A test of the stage on the device takes one through `common::gpu(…)`.
        let runs_on_gpu =
            files.iter().any(|f| fs::read_to_string(tests.join(format!("{f}.rs"))).is_ok_and(|t| t.contains("gpu(")));
        if !runs_on_gpu {
            missing.push(format!("{name}: no tests/{}.rs that runs a GPU (common::gpu)", files.join(".rs or tests/")));
        }
    }
    assert!(missing.is_empty(), "stages without a GPU parity test:\n{}", missing.join("\n"));
}

/// The engine's module graph, file by file: nodes are the files' module paths (`::`), and a
/// file naming a path (`crate::backend::gpu::buffers::DeviceLanes`) joins it to the file that
/// defines the path's longest prefix that is a module (`backend::gpu::buffers`). A file naming
/// its own folder's items (`super::Shared` from a file beside that `mod.rs`) joins nothing: a
/// folder's `mod.rs` holds what its files share.
fn engine_graph(files: &[(String, String)]) -> (BTreeSet<String>, Graph) {
    let modules: BTreeSet<Vec<String>> = files.iter().map(|(f, _)| module_path(f)).collect();
    let nodes: BTreeSet<String> = modules.iter().map(|m| m.join("::")).collect();
    let mut graph = Graph::new();
    for (file, text) in files {
        let here = module_path(file);
        let lines: Vec<&str> = text.lines().collect();
        for r in references(file, text, "matdem_engine") {
            let to = (0..=r.path.len()).rev().map(|k| &r.path[..k]).find(|p| modules.contains(*p)).unwrap();
            if here.starts_with(to) {
                continue;
            }
            let evidence = format!("src/{file}:{}: {}", r.line, lines[r.line - 1].trim());
            let e = graph.entry((here.join("::"), to.join("::"))).or_default();
            if !e.contains(&evidence) {
                e.push(evidence);
            }
        }
    }
    (nodes, graph)
}

#[test]
fn the_engines_modules_form_no_circle() {
    let (nodes, graph) = engine_graph(&sources());
    assert!(nodes.len() > 40 && graph.len() > 100, "the engine's modules were not read: {nodes:?}");
    let all = circles(&nodes, &graph);
    let found: Vec<String> = all
        .iter()
        .map(|c| format!("{{{}}}, e.g. {}", c.join(", "), describe_circle(&a_circle_through(&c[0], c, &graph), &graph)))
        .collect();
    assert!(
        found.is_empty(),
        "engine modules name each other in a circle (each group below names itself through the \
         others; one circle through it, with the line that makes each step). Move what both sides \
         need into a module of its own that names neither:\n{}",
        found.join("\n")
    );
}

/// The file-level graph on made-up files: a file naming another joins them, a file naming its
/// folder's `mod.rs` joins nothing.
#[test]
fn the_engine_graph_joins_the_files_that_name_each_other() {
    let files: Vec<(String, String)> = [
        ("lib.rs", "pub mod a; pub mod b;"),
        ("a/mod.rs", "mod x; mod y; pub use x::X; pub struct Shared;"),
        ("a/x.rs", "use super::Shared; use super::y::Y; pub struct X;"),
        ("a/y.rs", "use crate::b::deep::Z; pub struct Y;"),
        ("b/mod.rs", "pub mod deep;"),
        ("b/deep.rs", "use crate::a::x::X; pub struct Z;"),
    ]
    .iter()
    .map(|(p, t)| (p.to_string(), t.to_string()))
    .collect();
    let (nodes, g) = engine_graph(&files);
    let edges: Vec<String> = g.keys().map(|(a, b)| format!("{a}->{b}")).collect();
    assert_eq!(edges, ["a::x->a::y", "a::y->b::deep", "b::deep->a::x"]);
    assert_eq!(circles(&nodes, &g), [["a::x", "a::y", "b::deep"].map(String::from)]);
}
