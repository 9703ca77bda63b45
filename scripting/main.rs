//! The `matdem-rs` command: parses arguments and hands off to the library.

use clap::{Args, Parser, Subcommand, ValueEnum};
use matdem_engine::backend::gpu::device::{select, BackendChoice, Compute, GpuContext};
use matdem_engine::backend::RunControl;
use matdem_rs::bench::{run_bench, BenchConfig};
use matdem_rs::package::{pack, Package};
use matdem_rs::run::{parse_value, run_script, RunConfig, RunError};
use matdem_rs::sandbox::Limits;
use matdem_rs::study::{run_study, summary, StudyConfig, Vary};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

#[derive(Parser)]
#[command(
    name = "matdem-rs",
    version,
    about = "A discrete element method workbench scripted in Rhai, modelled on MatDEM",
    after_help = "Examples:\n  matdem-rs run examples/oedometer\n  matdem-rs run examples/oedometer --out out/full --set full=true\n  matdem-rs info examples/oedometer\n  matdem-rs pack examples/oedometer -o oedometer.tar\n  matdem-rs plan examples/oedometer\n  matdem-rs bench --json"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Backend {
    /// A hardware GPU when one is present, else the CPU backend.
    Auto,
    /// The native CPU backend (f64, multithreaded): the reference.
    Cpu,
    /// The wgpu compute backend (f32).
    Gpu,
}

#[derive(Subcommand)]
enum Command {
    /// Run a script or a packaged simulator (a folder with simulator.ron, or its .tar archive);
    /// everything it writes goes into one output folder.
    #[command(after_help = "Examples:\n  matdem-rs run examples/oedometer --out out/oedometer --set quick=true\n  \
        matdem-rs run oedometer.tar --set dt_rate=2\n  matdem-rs run my_script.rhai --set n=10\n  \
        matdem-rs run examples/oedometer --resume out/oedometer\n\n\
        Ctrl-C or SIGTERM finishes the current chunk of steps, saves what a resume needs in OUT/resume/ and exits \
        with 130;\n--resume continues from there (a second Ctrl-C stops at once, without saving).")]
    Run {
        /// A .rhai script, a package folder or a package archive (.tar).
        script: PathBuf,
        /// Output folder (default: out/<script name>; with --resume, the interrupted run's).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Continue the interrupted run whose output folder (or its resume/ folder) is DIR.
        #[arg(long, value_name = "DIR")]
        resume: Option<PathBuf>,
        /// A parameter the script reads as `params.NAME`; repeatable.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        #[arg(long, value_enum, default_value_t = Backend::Auto)]
        backend: Backend,
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// Print what a script's scene simulates and what it leaves out, without running it.
    Plan {
        /// A .rhai script, a package folder or a package archive (.tar).
        script: PathBuf,
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// An interactive session: models, variables and functions stay alive between lines.
    #[command(after_help = "Commands inside: :help, :help NAME, :vars, :load FILE, :quit. Ctrl-C cancels the\n\
        running balance, not the session. History: $MATDEM_HISTORY, else $XDG_DATA_HOME/matdem-rs/history,\n\
        else ~/.matdem_history.\n\nExample:\n  matdem-rs repl examples/oedometer/compress.rhai")]
    Repl {
        /// A script to run first; the session then reads files from its folder.
        script: Option<PathBuf>,
        /// Output folder (default: out/repl).
        #[arg(long)]
        out: Option<PathBuf>,
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// Describe a packaged simulator: what it does, its parameters (type, default, unit,
    /// range) and what it writes.
    #[command(after_help = "Example:\n  matdem-rs info examples/oedometer")]
    Info {
        /// A package folder (with simulator.ron) or its .tar archive.
        package: PathBuf,
    },
    /// Pack a simulator folder into one .tar archive that `run` and `info` take as is.
    #[command(after_help = "Example:\n  matdem-rs pack examples/oedometer -o oedometer.tar")]
    Pack {
        /// The package folder (with simulator.ron).
        package: PathBuf,
        /// The archive to write (default: NAME-VERSION.tar).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Time the standard lattice scene (20×20×50 Hertz–Mindlin spheres in a box of five walls,
    /// as LIGGGHTS is measured on) and print particle-steps per second.
    #[command(after_help = "Example:\n  RAYON_NUM_THREADS=2 matdem-rs bench --particles 100000 --json")]
    Bench {
        #[arg(long, value_enum, default_value_t = Backend::Cpu)]
        backend: Backend,
        /// About this many particles, keeping the 20:20:50 aspect (default: 20000).
        #[arg(long)]
        particles: Option<usize>,
        /// Timed steps.
        #[arg(long, default_value_t = 1000)]
        steps: u64,
        /// Untimed steps before timing.
        #[arg(long, default_value_t = 100)]
        warmup: u64,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Also time each named stage (CPU only): the same steps run as separate passes, one
        /// per stage, and each stage's share of them printed.
        #[arg(long)]
        profile: bool,
    },
    /// Print the script reference (Markdown): every function, property and stdlib procedure
    /// scripts can use, from what this binary registers.
    #[command(after_help = "Example:\n  matdem-rs doc > docs/script-reference.md")]
    Doc,
    /// Run a script at every combination of parameter values and chart the metric it reports
    /// against wall time: what accuracy costs.
    #[command(after_help = "The script reports its metric with `report(\"NAME\", value)`. Each setting runs in\n\
        OUT/runNN/; OUT/study.csv and OUT/study.svg/png compare them with the reference\n\
        (by default the slowest run that finished). `--vary backend=cpu,gpu` switches backends.\n\n\
        Example:\n  matdem-rs study examples/oedometer --vary dt_rate=0.25,0.5,1 --vary ring_mm=2.5,3.5 \\\n    \
        --set samples=1 --metric strain_no1 --out out/study")]
    Study {
        script: PathBuf,
        /// A parameter and the values to try, NAME=v1,v2,...; repeatable (every combination runs).
        #[arg(long, value_name = "NAME=V1,V2,...", required = true)]
        vary: Vec<matdem_rs::study::Vary>,
        /// The name the script reports with `report(NAME, value)`.
        #[arg(long)]
        metric: String,
        /// A parameter given to every run; repeatable.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// The setting errors are measured against, as NAME=VALUE,... (default: the slowest run).
        #[arg(long, value_name = "NAME=VALUE,...")]
        reference: Option<String>,
        /// Output folder (default: out/study).
        #[arg(long)]
        out: Option<PathBuf>,
        #[arg(long, value_enum, default_value_t = Backend::Auto)]
        backend: Backend,
        /// Settings run at once, each in its own process (they share the cores).
        #[arg(short = 'j', long, default_value_t = 1, value_parser = positive::<usize>)]
        jobs: usize,
    },
    /// Parameter sweeps as folders: plan the points, run them here or as a Slurm job array,
    /// see where they stand and merge their results into one table.
    #[command(
        after_help = "Examples:\n  matdem-rs sweep plan examples/oedometer --out out/sw --vary dt_rate=0.5,1 \\\n    \
        --vary seed=1,2,3 --set quick=true --set samples=1\n  matdem-rs sweep run out/sw --local -j 2\n  \
        matdem-rs sweep slurm out/sw --partition short --time 1:00:00 --cpus-per-task 4 --submit\n  \
        matdem-rs sweep status out/sw\n  matdem-rs sweep collect out/sw"
    )]
    Sweep {
        #[command(subcommand)]
        action: SweepCommand,
    },
}

#[derive(Subcommand)]
enum SweepCommand {
    /// Write DIR/sweep.ron (the source and its SHA-256, the design, every point's parameters)
    /// and one run folder per point.
    Plan {
        /// A .rhai script, a package folder or a package archive (.tar).
        source: PathBuf,
        /// The sweep folder.
        #[arg(long)]
        out: PathBuf,
        /// A parameter and its values, NAME=v1,v2,...; repeatable (every combination is a point).
        #[arg(long, value_name = "NAME=V1,V2,...", conflicts_with = "runs")]
        vary: Vec<Vary>,
        /// A CSV file of runs: a header of parameter names, one row per point (a design's runs).
        #[arg(long, value_name = "FILE.csv")]
        runs: Option<PathBuf>,
        /// A parameter given to every point; repeatable.
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        #[arg(long, value_enum, default_value_t = Backend::Auto)]
        backend: Backend,
        /// Plan over a different sweep already in the folder (its points run again).
        #[arg(long)]
        replace: bool,
    },
    /// Run the pending points (no outcome yet, or interrupted) on this machine.
    Run {
        dir: PathBuf,
        /// On this machine, in child processes (for a cluster, see `sweep slurm`).
        #[arg(long, required = true)]
        local: bool,
        /// Points run at once (they share the cores).
        #[arg(short = 'j', long, default_value_t = 1, value_parser = positive::<usize>)]
        jobs: usize,
        /// Run the points that failed again too.
        #[arg(long)]
        retry_failed: bool,
    },
    /// Write DIR/sweep.sbatch, a job array with one task per pending point, and with --submit
    /// hand it to sbatch. The binary and the source are reached by path (a shared file system).
    Slurm {
        dir: PathBuf,
        #[arg(long)]
        partition: Option<String>,
        /// Time limit of each task (e.g. 2:00:00).
        #[arg(long)]
        time: Option<String>,
        #[arg(long)]
        cpus_per_task: Option<u32>,
        /// Memory of each task (e.g. 4G).
        #[arg(long)]
        mem: Option<String>,
        #[arg(long)]
        account: Option<String>,
        /// At most this many tasks at once (--array=...%N).
        #[arg(long)]
        max_parallel: Option<u32>,
        /// Include the points that failed.
        #[arg(long)]
        retry_failed: bool,
        /// Submit it with sbatch and print the job id.
        #[arg(long)]
        submit: bool,
    },
    /// How many points are finished, failed (with each error), running or pending.
    Status { dir: PathBuf },
    /// Merge the points into DIR/sweep.csv (parameters, status, metrics) and DIR/timings.csv.
    Collect { dir: PathBuf },
    /// Run one point, as a Slurm array task does (INDEX counts from 0).
    #[command(hide = true)]
    Point { dir: PathBuf, index: usize },
}

/// The sandbox's limits, as typed. Zero is refused: Rhai reads it as "no limit".
#[derive(Args)]
struct LimitArgs {
    /// Most Rhai operations a run may take (native calls such as a balance count as one).
    #[arg(long, default_value_t = Limits::default().max_operations, value_parser = positive::<u64>)]
    max_operations: u64,
    /// Deepest nesting of function calls.
    #[arg(long, default_value_t = Limits::default().max_call_depth as u64, value_parser = clap::value_parser!(u64).range(1..=512))]
    max_call_depth: u64,
    /// Longest string, in bytes.
    #[arg(long, default_value_t = Limits::default().max_string_size, value_parser = positive::<usize>)]
    max_string_size: usize,
    /// Most items in one array.
    #[arg(long, default_value_t = Limits::default().max_array_size, value_parser = positive::<usize>)]
    max_array_size: usize,
    /// Most entries in one object map.
    #[arg(long, default_value_t = Limits::default().max_map_size, value_parser = positive::<usize>)]
    max_map_size: usize,
}

/// A limit of at least 1.
fn positive<T: std::str::FromStr + PartialEq + From<u8>>(text: &str) -> Result<T, String> {
    match text.parse::<T>() {
        Ok(v) if v == T::from(0) => {
            Err("0 would switch the limit off; give at least 1 (or leave the option out for the default)".into())
        }
        Ok(v) => Ok(v),
        Err(_) => Err(format!("`{text}` is not a whole number")),
    }
}

impl LimitArgs {
    fn resolve(&self) -> Limits {
        Limits {
            max_operations: self.max_operations,
            max_call_depth: self.max_call_depth as usize,
            max_string_size: self.max_string_size,
            max_array_size: self.max_array_size,
            max_map_size: self.max_map_size,
        }
    }
}

type Params = Vec<(String, rhai::Dynamic)>;

/// The package `script` names, if it is one, and the script's parameters: a package's
/// defaults with each `--set` checked against its manifest, or a plain script's values typed
/// by their look.
fn resolve_source(script: &std::path::Path, set: &[String]) -> Result<(Option<Package>, Params), String> {
    match Package::detect(script).map_err(|e| format!("error: {e}"))? {
        Some(p) => {
            let params = p.params(set).map_err(|e| format!("error: {e}\nnothing was run"))?;
            Ok((Some(p), params))
        }
        None => Ok((None, params(set)?)),
    }
}

fn params(set: &[String]) -> Result<Vec<(String, rhai::Dynamic)>, String> {
    set.iter()
        .map(|s| match s.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => {
                matdem_rs::package::check_param_name(k.trim()).map_err(|e| format!("error: --set {s}: {e}"))?;
                Ok((k.trim().to_string(), parse_value(v.trim())))
            }
            _ => Err(format!("error: --set expects NAME=VALUE, got `{s}`")),
        })
        .collect()
}

/// Mesa's Vulkan drivers print `error: XDG_RUNTIME_DIR is invalid or not set` when probing
/// adapters where it is unset (containers, CI, ssh without a session), though nothing here
/// needs it; give them a private folder so `--backend auto` stays quiet.
fn quiet_mesa() {
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

fn main() -> ExitCode {
    quiet_mesa();
    let cli = Cli::parse();
    let (cfg, backend) = match cli.command {
        Command::Run { script, out, resume, set, backend, limits } => {
            if resume.is_some() && !set.is_empty() {
                eprintln!(
                    "error: a resumed run keeps the parameters of the interrupted one (see its run.ron); drop --set"
                );
                return ExitCode::from(2);
            }
            let (package, params) = match resolve_source(&script, &set) {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("{e}");
                    return ExitCode::from(2);
                }
            };
            let stem = match &package {
                Some(p) => p.manifest.name.clone().into(),
                None => script.file_stem().unwrap_or_default().to_os_string(),
            };
            let out_dir = match (out, &resume) {
                (Some(o), Some(dir)) => {
                    if let Err(e) = same_folder(&o, &matdem_rs::resume::run_folder(dir)) {
                        eprintln!("error: {e}");
                        return ExitCode::from(2);
                    }
                    o
                }
                (Some(o), None) => o,
                (None, Some(dir)) => matdem_rs::resume::run_folder(dir),
                (None, None) => matdem_rs::run::default_out_dir(&stem),
            };
            let progress = std::io::stderr().is_terminal();
            let control = RunControl::default();
            if let Err(e) = stop_on_signals(&control) {
                eprintln!("warning: Ctrl-C and SIGTERM will stop the run without saving a resume point ({e})");
            }
            let cfg = RunConfig {
                script,
                out_dir,
                params,
                progress,
                plan_only: false,
                backend: String::new(),
                control,
                resume,
                gpu: None,
                package,
                limits: limits.resolve(),
            };
            (cfg, backend)
        }
        Command::Plan { script, set, limits } => {
            let (package, params) = match resolve_source(&script, &set) {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("{e}");
                    return ExitCode::from(2);
                }
            };
            let cfg = RunConfig {
                script,
                out_dir: PathBuf::from("out/plan"),
                params,
                progress: false,
                plan_only: true,
                backend: "cpu (f64)".to_string(),
                control: RunControl::default(),
                resume: None,
                gpu: None,
                package,
                limits: limits.resolve(),
            };
            (cfg, Backend::Cpu)
        }
        Command::Info { package } => return info(&package),
        Command::Repl { script, out, limits } => {
            let out_dir = out.unwrap_or_else(|| PathBuf::from("out/repl"));
            let cfg = matdem_rs::repl::ReplConfig { script, out_dir, limits: limits.resolve() };
            return match matdem_rs::repl::run_repl(cfg) {
                Ok(code) => ExitCode::from(code),
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(2)
                }
            };
        }
        Command::Pack { package, output } => return pack_command(&package, output),
        Command::Doc => {
            let host = std::rc::Rc::new(matdem_rs::api::Host::new(PathBuf::from("out/doc")));
            print!("{}", matdem_rs::api::reference::markdown(&matdem_rs::new_engine(host)));
            return ExitCode::SUCCESS;
        }
        Command::Bench { backend, particles, steps, warmup, json, profile } => {
            return bench(backend, BenchConfig { particles, warmup, steps, json, profile, gpu: None });
        }
        Command::Study { script, vary, metric, set, reference, out, backend, jobs } => {
            return study(script, vary, metric, set, reference, out, backend, jobs);
        }
        Command::Sweep { action } => return sweep(action),
    };
    let mut cfg = cfg;
    if !cfg.plan_only {
        match open_backend(backend) {
            Ok(gpu) => {
                cfg.backend = match &gpu {
                    Some(ctx) => format!("gpu (f32) on {}", ctx.describe()),
                    None => "cpu (f64)".to_string(),
                };
                cfg.gpu = gpu;
            }
            Err(code) => return code,
        }
    }
    match run_script(&cfg) {
        Ok(written) => {
            if !cfg.plan_only && !written.is_empty() {
                eprintln!("wrote {} file(s) under {}", written.len(), cfg.out_dir.display());
            }
            ExitCode::SUCCESS
        }
        Err(e @ RunError::Setup(_)) => {
            eprintln!("{e}");
            ExitCode::from(e.exit_code())
        }
        Err(e) => {
            eprint!("{e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// A resumed run writes where the interrupted one wrote: `--out` may only name that folder.
fn same_folder(out: &std::path::Path, run_folder: &std::path::Path) -> Result<(), String> {
    let real = |p: &std::path::Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    if real(out) == real(run_folder) {
        return Ok(());
    }
    Err(format!(
        "--resume continues the run in {}, and writes its remaining outputs there; drop --out {} (or copy the \
         folder there first and resume from the copy)",
        run_folder.display(),
        out.display()
    ))
}

/// Ctrl-C and SIGTERM set the run's cancel flag: the engine finishes its chunk of steps and
/// the host saves a resume point. A second signal, with the flag already set, exits at once.
fn stop_on_signals(control: &RunControl) -> std::io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    for sig in [SIGINT, SIGTERM] {
        // Registered first, so it sees the flag as it was before this signal set it.
        flag::register_conditional_shutdown(sig, 130, control.cancel.clone())?;
        flag::register(sig, control.cancel.clone())?;
    }
    Ok(())
}

/// Opens the device `--backend` asks for and says on stderr which one runs (and, for `auto`
/// on the CPU, why). `--backend gpu` without a usable adapter ends the command (exit 2).
fn open_backend(backend: Backend) -> Result<Option<Arc<GpuContext>>, ExitCode> {
    let choice = match backend {
        Backend::Auto => BackendChoice::Auto,
        Backend::Cpu => BackendChoice::Cpu,
        Backend::Gpu => BackendChoice::Gpu,
    };
    match select(choice) {
        Ok(Compute::Gpu(ctx)) => {
            let note = if ctx.is_software() { " — a software device: correct, not fast" } else { "" };
            eprintln!("backend: gpu (f32) on {}{note}", ctx.describe());
            Ok(Some(ctx))
        }
        Ok(Compute::Cpu { reason }) => {
            // Passing over a software adapter is the right choice, not news on every run;
            // other reasons (no adapter, a device that failed to open) are said.
            if reason.contains("software adapter") {
                eprintln!("backend: cpu (f64, {} threads)", rayon_threads());
            } else {
                eprintln!("backend: cpu (f64, {} threads): {reason}", rayon_threads());
            }
            Ok(None)
        }
        Err(e) => {
            eprintln!("error: {e}");
            Err(ExitCode::from(2))
        }
    }
}

fn bench(backend: Backend, mut cfg: BenchConfig) -> ExitCode {
    match open_backend(backend) {
        Ok(gpu) => cfg.gpu = gpu,
        Err(code) => return code,
    }
    match run_bench(&cfg) {
        Ok(out) => {
            print!("{out}");
            ExitCode::SUCCESS
        }
        Err(msg) => {
            eprintln!("{msg}");
            ExitCode::from(2)
        }
    }
}

fn study(
    script: PathBuf,
    vary: Vec<Vary>,
    metric: String,
    fixed: Vec<String>,
    reference: Option<String>,
    out: Option<PathBuf>,
    backend: Backend,
    jobs: usize,
) -> ExitCode {
    let reference = match reference.map(|r| parse_reference(&r)).transpose() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let exe = match own_exe() {
        Ok(p) => p,
        Err(code) => return code,
    };
    let backend = backend_name(backend);
    let control = RunControl::default();
    if let Err(e) = stop_on_signals(&control) {
        eprintln!("warning: Ctrl-C and SIGTERM will stop the study without letting its running setting save ({e})");
    }
    let cfg = StudyConfig {
        control,
        exe,
        script,
        out_dir: out.unwrap_or_else(|| PathBuf::from("out/study")),
        vary,
        fixed,
        metric,
        reference,
        backend,
        jobs,
    };
    // Each setting's run locks its own runNN folder; the sweep holds the folder around them.
    match run_study(&cfg, |line| eprintln!("{line}")) {
        Ok((s, written)) => {
            print!("{}", summary(&s, &cfg.metric));
            eprintln!("wrote {} file(s) under {}", written.len(), cfg.out_dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(if cfg.control.is_cancelled() { 130 } else { 1 })
        }
    }
}

/// This binary, which runs each point of a study or sweep.
fn own_exe() -> Result<PathBuf, ExitCode> {
    std::env::current_exe().map_err(|e| {
        eprintln!("error: cannot find the matdem-rs binary to run each point: {e}");
        ExitCode::from(2)
    })
}

fn backend_name(backend: Backend) -> String {
    backend.to_possible_value().map_or("auto".to_string(), |v| v.get_name().to_string())
}

fn sweep(action: SweepCommand) -> ExitCode {
    match sweep_action(action) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn sweep_action(action: SweepCommand) -> Result<(), String> {
    use matdem_rs::sweep::{collect, plan, slurm};
    match action {
        SweepCommand::Plan { source, out, vary, runs, set, backend, replace } => {
            let fixed = set
                .iter()
                .map(|f| match f.split_once('=') {
                    Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
                    _ => Err(format!("--set expects NAME=VALUE, got `{f}`")),
                })
                .collect::<Result<Vec<_>, String>>()?;
            let mut request = plan::PlanRequest {
                source,
                dir: out.clone(),
                backend: backend_name(backend),
                fixed,
                design: plan::Design::Runs { from: String::new() },
                runs: Vec::new(),
                study: None,
                replace,
            };
            let planned = match runs {
                Some(file) => {
                    request.runs = plan::read_runs_csv(&file)?;
                    request.design = plan::Design::Runs { from: plan::absolute(&file).display().to_string() };
                    plan::plan(request)?
                }
                None if vary.is_empty() => return Err("give --vary NAME=v1,v2,... or --runs FILE.csv".into()),
                None => {
                    let mut names: Vec<&str> = Vec::new();
                    for v in &vary {
                        if names.contains(&v.name.as_str()) {
                            return Err(format!("--vary {} is given twice; list all its values in one --vary", v.name));
                        }
                        names.push(&v.name);
                    }
                    plan::plan_grid(request, vary.into_iter().map(|v| (v.name, v.values)).collect())?
                }
            };
            warn_refused_values(&planned);
            eprintln!(
                "planned {} point(s) in {}; run them with `matdem-rs sweep run {} --local -j N` or `matdem-rs sweep \
                 slurm {} --submit`",
                planned.points.len(),
                out.display(),
                out.display(),
                out.display()
            );
            Ok(())
        }
        SweepCommand::Run { dir, local: _, jobs, retry_failed } => {
            let planned = plan::load(&dir)?;
            let control = RunControl::default();
            if let Err(e) = stop_on_signals(&control) {
                eprintln!("warning: Ctrl-C and SIGTERM will stop the sweep without letting its points save ({e})");
            }
            let exe = own_exe().map_err(|_| "cannot find the matdem-rs binary".to_string())?;
            let opts = matdem_rs::sweep::LocalOptions { jobs, retry_failed, exe, control: control.clone() };
            let result = matdem_rs::sweep::run_local(&dir, &planned, &opts, |line| eprintln!("{line}"));
            if let Err(e) = result {
                if control.is_cancelled() {
                    eprintln!("error: {e}");
                    std::process::exit(130);
                }
                return Err(e);
            }
            let results = collect::results(&dir, &planned)?;
            eprint!("{}", collect::status_text(&dir, &planned, &results));
            Ok(())
        }
        SweepCommand::Slurm {
            dir,
            partition,
            time,
            cpus_per_task,
            mem,
            account,
            max_parallel,
            retry_failed,
            submit,
        } => {
            let planned = plan::load(&dir)?;
            let exe = own_exe().map_err(|_| "cannot find the matdem-rs binary".to_string())?;
            let opts = slurm::SlurmOptions { partition, time, cpus_per_task, mem, account, max_parallel, retry_failed };
            let Some((script, tasks)) = slurm::write_script(&dir, &planned, &exe, &opts)? else {
                eprintln!("every point of {} is finished; nothing to submit", dir.display());
                return Ok(());
            };
            eprintln!("wrote {} ({tasks} array task(s))", script.display());
            if submit {
                let id = slurm::submit(&script)?;
                println!("{id}");
                eprintln!(
                    "submitted job {id}; follow it with `matdem-rs sweep status {}`, merge with `matdem-rs sweep \
                     collect {}`",
                    dir.display(),
                    dir.display()
                );
            } else {
                eprintln!("submit it with `sbatch {}`", script.display());
            }
            Ok(())
        }
        SweepCommand::Status { dir } => {
            let planned = plan::load(&dir)?;
            let results = collect::results(&dir, &planned)?;
            print!("{}", collect::status_text(&dir, &planned, &results));
            Ok(())
        }
        SweepCommand::Collect { dir } => {
            let planned = plan::load(&dir)?;
            let results = collect::results(&dir, &planned)?;
            let written = collect::write_collect(&dir, &planned, &results)?;
            print!("{}", collect::status_text(&dir, &planned, &results));
            eprintln!("wrote {} file(s) under {}", written.len(), dir.display());
            Ok(())
        }
        SweepCommand::Point { dir, index } => {
            let planned = plan::load(&dir)?;
            if index >= planned.points.len() {
                return Err(format!("the sweep has {} point(s); index {index} is not one", planned.points.len()));
            }
            matdem_rs::sweep::point::check_source(&planned)?;
            let name = &planned.points[index].name;
            if !matdem_rs::sweep::point::is_pending(&dir, name, true)? {
                eprintln!("{name} finished already; skipped");
                return Ok(());
            }
            let control = RunControl::default();
            if let Err(e) = stop_on_signals(&control) {
                eprintln!("warning: SIGTERM will stop the point without letting it save ({e})");
            }
            let exe = own_exe().map_err(|_| "cannot find the matdem-rs binary".to_string())?;
            let outcome = matdem_rs::sweep::point::run_point(&dir, &planned, index, &exe, None, &control)?;
            eprintln!(
                "{name}: {:?} in {:.1} s{}",
                outcome.status,
                outcome.wall_s,
                outcome.error.map(|e| format!(": {e}")).unwrap_or_default()
            );
            Ok(())
        }
    }
}

/// Points whose values a package refuses still run (and fail with the reason, so the sweep's
/// table shows it); say so now rather than after the queue.
fn warn_refused_values(planned: &matdem_rs::sweep::SweepPlan) {
    let Ok(Some(package)) = Package::detect(&planned.source) else { return };
    for p in &planned.points {
        let set: Vec<String> = p
            .parameters
            .iter()
            .chain(&planned.fixed)
            .filter(|(n, _)| n != "backend")
            .map(|(n, v)| format!("{n}={v}"))
            .collect();
        if let Err(e) = package.params(&set) {
            eprintln!("warning: {} will fail: {e}", p.name);
        }
    }
}

fn parse_reference(s: &str) -> Result<Vec<(String, String)>, String> {
    s.split(',')
        .map(|kv| match kv.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
            _ => Err(format!("--reference expects NAME=VALUE,..., got `{s}`")),
        })
        .collect()
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn info(path: &std::path::Path) -> ExitCode {
    match Package::open(path) {
        Ok(p) => {
            print!("{}", p.describe());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn pack_command(dir: &std::path::Path, output: Option<PathBuf>) -> ExitCode {
    let output = match output {
        Some(o) => o,
        None => match Package::open(dir) {
            Ok(p) => PathBuf::from(format!("{}-{}.tar", p.manifest.name, p.manifest.version)),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        },
    };
    match pack(dir, &output) {
        Ok(n) => {
            eprintln!("packed {n} file(s) into {}; run it with `matdem-rs run {}`", output.display(), output.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
