//! `bench`: the standard scene, timed.

use super::{open_backend, Failure, Outcome};
use crate::cli::Backend;
use matdem_rs::bench::{run_bench, BenchConfig};
use matdem_rs::out;
use matdem_rs::run_backend::RunBackend;
use std::process::ExitCode;

/// Times the scene `cfg` describes on `backend` (`cfg.gpu` is filled in here).
pub fn bench(backend: Backend, cfg: BenchConfig) -> Outcome {
    // A bench times one backend: `auto` benches the GPU a run's speed test would measure
    // (a run then chooses by its own scene), else the CPU.
    let gpu = match open_backend(backend)? {
        RunBackend::Gpu(ctx) | RunBackend::Auto(ctx) => Some(ctx),
        RunBackend::Cpu => None,
    };
    let out = run_bench(&BenchConfig { gpu, ..cfg }).map_err(|msg| Failure::said(2, msg))?;
    out!("{out}");
    Ok(ExitCode::SUCCESS)
}
