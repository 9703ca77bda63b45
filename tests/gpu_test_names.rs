//! Every test that runs on a GPU says so in its path, so that `.ci/device-check run`, which runs
//! on a hardware GPU the tests of the engine's and the host's integration binaries whose paths
//! hold one of the words of `.ci/gpu-tests`, runs them all (until 2026-12-06 fourteen ran on
//! lavapipe only: `steady_flow_on_the_device_books_every_kilogram`, `study_varies_the_backend`, …).
//!
//! A test runs on a GPU when its body takes a device (`gpu(…)`, `common::gpu(…)`), builds a
//! GPU simulation (`with_gpu`) or passes `"gpu"` (a `--backend gpu` run). Its path is its file's
//! module, the inline modules around it and its name (`tangential_damping::gpu::…`).

use std::fs;
use std::path::Path;

use crate::module_graph::{code_only, rust_files, tokens};

/// The words `.ci/device-check` selects the GPU tests by.
fn device_check_words() -> Vec<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(".ci/gpu-tests");
    let text = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.split_whitespace().map(String::from).collect()
}

/// (path, whether it runs on a GPU, file:line) of each `#[test]` function in `text`, a test file
/// whose module is `module`.
fn tests_in(module: &str, file: &str, text: &str) -> Vec<(String, bool, String)> {
    let code = code_only(text);
    let raw: Vec<&str> = text.lines().collect();
    let t = tokens(&code);
    let at = |k: usize| t.get(k).map(|x| x.text.as_str()).unwrap_or("");
    let mut out = Vec::new();
    // Inline modules open around the scan: (name, brace depth inside it).
    let mut mods: Vec<(String, usize)> = Vec::new();
    let (mut depth, mut test_attr) = (0usize, false);
    let mut k = 0;
    while k < t.len() {
        match at(k) {
            "{" => depth += 1,
            "}" => {
                depth -= 1;
                if mods.last().is_some_and(|(_, d)| *d == depth + 1) {
                    mods.pop();
                }
            }
            "#" if at(k + 1) == "[" && at(k + 2) == "test" && at(k + 3) == "]" => test_attr = true,
            "mod" if at(k + 2) == "{" => {
                mods.push((at(k + 1).to_string(), depth + 1));
            }
            "fn" if test_attr => {
                test_attr = false;
                let name = at(k + 1).to_string();
                // The body: from the first `{` after the name to its match.
                let mut j = k;
                while at(j) != "{" {
                    j += 1;
                }
                let (first, mut level) = (t[j].line, 0usize);
                let mut end = j;
                loop {
                    match at(end) {
                        "{" => level += 1,
                        "}" => {
                            level -= 1;
                            if level == 0 {
                                break;
                            }
                        }
                        _ => {}
                    }
                    end += 1;
                }
                let last = t[end].line;
                let body_code: String =
                    code.lines().skip(first - 1).take(last - first + 1).collect::<Vec<_>>().join("\n");
                let body_raw = raw[first - 1..last].join("\n");
                let gpu = body_code.contains("gpu(") || body_code.contains("with_gpu") || body_raw.contains("\"gpu\"");
                let path: Vec<&str> = std::iter::once(module)
                    .chain(mods.iter().map(|(m, _)| m.as_str()))
                    .chain([name.as_str()])
                    .collect();
                out.push((path.join("::"), gpu, format!("{file}:{}", t[k].line)));
            }
            _ => {}
        }
        k += 1;
    }
    out
}

/// Every `#[test]` of the engine's and the host's integration tests: (path, runs on a GPU, where).
fn integration_tests() -> Vec<(String, bool, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = Vec::new();
    for dir in ["engine/tests", "tests"] {
        for f in rust_files(&root.join(dir)) {
            let rel = f.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
            let module = f.file_stem().unwrap().to_string_lossy().to_string();
            all.extend(tests_in(&module, &rel, &fs::read_to_string(&f).unwrap()));
        }
    }
    all
}

#[test]
fn every_test_that_runs_on_a_gpu_is_one_the_device_check_runs() {
    let words = device_check_words();
    let all = integration_tests();
    let on_gpu: Vec<_> = all.iter().filter(|(_, gpu, _)| *gpu).collect();
    // The reader found the tests: the engine's parity tests among them, and not every test.
    assert!(
        on_gpu.len() > 80 && on_gpu.len() < all.len() / 2,
        "{} of {} tests found on a GPU",
        on_gpu.len(),
        all.len()
    );
    assert!(on_gpu.iter().any(|(p, ..)| p == "tangential_damping::gpu::tangential_dashpot_impacts_match_cpu"));
    let missed: Vec<String> = on_gpu
        .iter()
        .filter(|(p, ..)| !words.iter().any(|w| p.contains(w.as_str())))
        .map(|(p, _, at)| format!("{at}: {p}"))
        .collect();
    assert!(
        missed.is_empty(),
        "these tests run on a GPU, but their paths hold none of {words:?} (.ci/gpu-tests), so \
         .ci/device-check would not run them on the hardware: name what they prove on the GPU \
         (`…_on_the_cpu_and_the_gpu`):\n{}",
        missed.join("\n")
    );
}

/// The reader on a made-up file: a test in an inline module, one that takes a device, one
/// that runs the binary with `--backend gpu`, and one on the CPU alone.
#[test]
fn the_reader_finds_each_tests_path_and_whether_it_takes_a_gpu() {
    let text = r#"
#[test]
fn on_the_cpu() { let x = 1; }
mod gpu {
    #[test]
    fn takes_a_device() { let Some(ctx) = gpu("x") else { return }; }
}
#[cfg(feature = "gpu")]
#[test]
fn runs_the_binary() {
    // a comment that says gpu( is no use of one
    run(&["--backend", "gpu"]);
}
#[test]
fn comments_only() { /* with_gpu */ }
"#;
    let found: Vec<(String, bool)> = tests_in("f", "f.rs", text).into_iter().map(|(p, g, _)| (p, g)).collect();
    let want = [
        ("f::on_the_cpu", false),
        ("f::gpu::takes_a_device", true),
        ("f::runs_the_binary", true),
        ("f::comments_only", false),
    ];
    assert_eq!(found, want.map(|(p, g)| (p.to_string(), g)));
}
