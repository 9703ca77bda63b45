//! `bench`: the standard scene, timed.

use super::{open_backend, Failure, Outcome};
use crate::cli::Backend;
use matdem_rs::bench::{run_bench, BenchConfig, BenchField};
use matdem_rs::run_backend::RunBackend;
use std::process::ExitCode;

pub fn bench(
    backend: Backend,
    particles: Option<usize>,
    steps: u64,
    warmup: u64,
    json: bool,
    profile: bool,
    fields: Vec<BenchField>,
) -> Outcome {
    // A bench times one backend: `auto` benches the GPU a run's speed test would measure
    // (a run then chooses by its own scene), else the CPU.
    let gpu = match open_backend(backend)? {
        RunBackend::Gpu(ctx) | RunBackend::Auto(ctx) => Some(ctx),
        RunBackend::Cpu => None,
    };
    let cfg = BenchConfig { particles, warmup, steps, json, profile, gpu, fields };
    let out = run_bench(&cfg).map_err(|msg| Failure::said(2, msg))?;
    print!("{out}");
    Ok(ExitCode::SUCCESS)
}
