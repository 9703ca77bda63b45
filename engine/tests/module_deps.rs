//! The engine's dependency directions, read from its source files:
//!
//! - only the CPU backend names the CPU backend: no file outside `src/backend/cpu/` mentions
//!   `backend::cpu` (the model, the neighbour rows, the run loop and the GPU backend depend
//!   on the engine's modules, not on one backend; `backend/mod.rs` names its two backends as
//!   `cpu::…` and `gpu::…`);
//! - the GPU backend never reaches into the CPU backend, nor the CPU backend into the GPU's;
//! - the engine never imports the host: no `rhai`, `plotters`, `clap` or `matdem_rs` path in
//!   its source and none of them among its Cargo dependencies.
//!
//! A failure names the file and the line.

use std::fs;
use std::path::{Path, PathBuf};

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

/// The engine's source files as (path relative to `src/`, with `/` separators; text).
fn sources() -> Vec<(String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
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

#[test]
fn only_the_cpu_backend_names_the_cpu_backend() {
    let found = mentions(|p| !p.starts_with("backend/cpu/"), "backend::cpu");
    assert!(
        found.is_empty(),
        "outside backend/cpu/, use the engine's modules (neighbours, plan, status, simulation) or the \
         Backend trait, not the CPU backend:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_backends_do_not_reach_into_each_other() {
    let gpu = mentions(|p| p.starts_with("backend/gpu/"), "cpu::");
    assert!(gpu.is_empty(), "the GPU backend names the CPU backend:\n{}", gpu.join("\n"));
    let cpu = mentions(|p| p.starts_with("backend/cpu/"), "gpu::");
    assert!(cpu.is_empty(), "the CPU backend names the GPU backend:\n{}", cpu.join("\n"));
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

/// Where a stage's CPU twin may live: the CPU backend's file, or the engine-level module both
/// backends share.
fn cpu_twin(src: &Path, name: &str) -> Option<PathBuf> {
    [format!("backend/cpu/{name}.rs"), format!("{name}.rs"), format!("{name}/mod.rs")]
        .into_iter()
        .map(|p| src.join(p))
        .find(|p| p.is_file())
}

#[test]
fn every_stage_has_a_wgsl_file_a_gpu_kernel_file_and_a_cpu_twin_of_its_name() {
    let engine = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = engine.join("src");
    let mut missing = Vec::new();
    for stage in matdem_engine::plan::Stage::ALL {
        let name = stage.name();
        let wgsl = engine.join(format!("../shaders/{name}.wgsl"));
        let kernel = src.join(format!("backend/gpu/{name}.rs"));
        for p in [wgsl, kernel] {
            if !p.is_file() {
                missing.push(format!("{name}: {}", p.display()));
            }
        }
        if cpu_twin(&src, name).is_none() {
            missing.push(format!("{name}: no backend/cpu/{name}.rs, src/{name}.rs or src/{name}/mod.rs"));
        }
    }
    assert!(missing.is_empty(), "stages without their files:\n{}", missing.join("\n"));
}
