//! What each subcommand does. A command returns the exit code it ends with, or a
//! [`Failure`] that `main` prints; the work itself is the library's.

mod bench;
mod package;
mod scripts;
mod study;
mod sweep;

use crate::cli::{Backend, Command};
use clap::ValueEnum;
#[cfg(feature = "gpu")]
use matdem_engine::backend::gpu::device::{select, BackendChoice, Compute};
use matdem_engine::backend::RunControl;
use matdem_rs::eoutln;
use matdem_rs::run_backend::RunBackend;
use std::path::PathBuf;
use std::process::ExitCode;

/// Why a command stopped: the text for stderr (whole lines) and the exit code.
pub struct Failure {
    pub code: u8,
    pub text: String,
}

impl Failure {
    /// Exit code 2 with `error: ` and the message: the command could not do what was asked.
    fn error(message: impl std::fmt::Display) -> Self {
        Failure { code: 2, text: format!("error: {message}\n") }
    }

    /// A message that already says what it is (it carries its own `error:` prefix).
    fn said(code: u8, text: impl Into<String>) -> Self {
        let mut text = text.into();
        if !text.ends_with('\n') {
            text.push('\n');
        }
        Failure { code, text }
    }
}

pub type Outcome = Result<ExitCode, Failure>;

pub fn dispatch(command: Command) -> Outcome {
    match command {
        Command::Run { script, out, resume, mut set, set_file, backend, limits } => {
            if let Some(file) = set_file {
                set.extend(scripts::read_set_file(&file)?);
            }
            scripts::run(script, out, resume, &set, backend, limits.resolve())
        }
        Command::Plan { script, set, limits } => scripts::plan(script, &set, limits.resolve()),
        Command::Repl { script, out, limits } => scripts::repl(script, out, limits.resolve()),
        Command::Doc => scripts::doc(),
        Command::Info { package } => package::info(&package),
        Command::Pack { package, output } => package::pack(&package, output),
        Command::Bench { backend, particles, steps, warmup, json, profile, fields, scene } => {
            let cfg =
                matdem_rs::bench::BenchConfig { particles, warmup, steps, json, profile, gpu: None, fields, scene };
            bench::bench(backend, cfg)
        }
        Command::Study { script, vary, metric, set, reference, out, backend, jobs, max_points } => {
            study::study(study::StudyArgs {
                script,
                vary,
                metric,
                fixed: set,
                reference,
                out,
                backend,
                jobs,
                max_points,
            })
        }
        Command::Sweep { action } => sweep::sweep(action).map(|()| ExitCode::SUCCESS).map_err(Failure::error),
    }
}

/// Mesa's Vulkan drivers print `error: XDG_RUNTIME_DIR is invalid or not set` when probing
/// adapters where it is unset (containers, CI, ssh without a session), though nothing here
/// needs it; give them a private folder so `--backend auto` stays quiet.
pub fn quiet_mesa() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    let dir = std::env::temp_dir().join("matdem-rs-runtime");
    let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
    // Only a folder that is ours and private will do; otherwise Mesa may print its note.
    let ours = std::fs::metadata(&dir).is_ok_and(|m| {
        m.is_dir()
            && m.permissions().mode() & 0o077 == 0
            && std::fs::metadata("/proc/self").is_ok_and(|p| p.uid() == m.uid())
    });
    if ours {
        // Still single-threaded: nothing else reads the environment yet.
        std::env::set_var("XDG_RUNTIME_DIR", dir);
    }
}

/// Ctrl-C and SIGTERM set the run's cancel flag: the engine finishes its chunk of steps and
/// the host saves a resume point. A second signal, with the flag already set, exits at once.
/// `what` says what a failure to install the handlers costs, e.g. "the run without saving a
/// resume point".
fn stop_on_signals(control: &RunControl, what: &str) {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    let install = || -> std::io::Result<()> {
        for sig in [SIGINT, SIGTERM] {
            // Registered first, so it sees the flag as it was before this signal set it.
            flag::register_conditional_shutdown(sig, 130, control.cancel.clone())?;
            flag::register(sig, control.cancel.clone())?;
        }
        Ok(())
    };
    if let Err(e) = install() {
        eoutln!("warning: Ctrl-C and SIGTERM will stop {what} ({e})");
    }
}

/// Opens the device `--backend` asks for and says on stderr which one runs (and, for `auto`
/// on the CPU, why). With a GPU to measure, `auto` is left for the first run to decide
/// ([`matdem_rs::run_backend`]). `--backend gpu` without a usable adapter ends the command
/// (exit 2).
#[cfg(feature = "gpu")]
fn open_backend(backend: Backend) -> Result<RunBackend, Failure> {
    let choice = match backend {
        Backend::Auto => BackendChoice::Auto,
        Backend::Cpu => BackendChoice::Cpu,
        Backend::Gpu => BackendChoice::Gpu,
    };
    let threads = cpu_threads();
    match select(choice).map_err(Failure::error)? {
        Compute::Gpu(ctx) if choice == BackendChoice::Auto => {
            eoutln!(
                "backend: auto, cpu (f64, {threads}) or gpu (f32) on {}: a speed test at the first run decides",
                ctx.describe()
            );
            Ok(RunBackend::Auto(ctx))
        }
        Compute::Gpu(ctx) => {
            let note = if ctx.is_software() { " — a software device: correct, not fast" } else { "" };
            eoutln!("backend: gpu (f32) on {}{note}", ctx.describe());
            Ok(RunBackend::Gpu(ctx))
        }
        Compute::Cpu { reason } => {
            // Passing over a software adapter is the right choice, not news on every run;
            // other reasons (no adapter, a device that failed to open) are said.
            if reason.contains("software adapter") {
                eoutln!("backend: cpu (f64, {threads})");
            } else {
                eoutln!("backend: cpu (f64, {threads}): {reason}");
            }
            Ok(RunBackend::Cpu)
        }
    }
}

/// [`open_backend`] in a build without the GPU backend (the `gpu` feature off): the CPU, and
/// `--backend gpu` ends the command as it does without a usable adapter (exit 2).
#[cfg(not(feature = "gpu"))]
fn open_backend(backend: Backend) -> Result<RunBackend, Failure> {
    if matches!(backend, Backend::Gpu) {
        return Err(Failure::error(
            "no usable GPU: this build of matdem-rs has no GPU backend (built without the `gpu` feature); run with \
             --backend cpu (or auto, which falls back to the CPU)",
        ));
    }
    let threads = cpu_threads();
    eoutln!("backend: cpu (f64, {threads})");
    Ok(RunBackend::Cpu)
}

/// The CPU backend's threads, as the backend line says them: its pool's (`RAYON_NUM_THREADS`),
/// not the machine's cores.
fn cpu_threads() -> String {
    match matdem_engine::backend::CpuBackend::threads() {
        1 => "1 thread".into(),
        n => format!("{n} threads"),
    }
}

/// This binary, which runs each point of a study or sweep.
fn own_exe() -> Result<PathBuf, String> {
    std::env::current_exe().map_err(|e| format!("cannot find the matdem-rs binary to run each point: {e}"))
}

fn backend_name(backend: Backend) -> String {
    backend.to_possible_value().map_or("auto".to_string(), |v| v.get_name().to_string())
}
