//! The command line: every subcommand, its arguments and their checks (clap). What each
//! command does is in `commands/`.

use clap::{Args, Parser, Subcommand, ValueEnum};
use matdem_rs::sandbox::Limits;
use matdem_rs::study::Vary;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "matdem-rs",
    version,
    about = "A discrete element method workbench scripted in Rhai, modelled on MatDEM",
    after_help = "Examples:\n  matdem-rs run examples/oedometer\n  matdem-rs run examples/oedometer --out out/full --set full=true\n  matdem-rs info examples/oedometer\n  matdem-rs pack examples/oedometer -o oedometer.tar\n  matdem-rs plan examples/oedometer\n  matdem-rs bench --json"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// With a hardware GPU, a speed test of the scene on it and on the CPU at the first run,
    /// then the faster for the whole run; without one, the CPU backend.
    Auto,
    /// The native CPU backend (f64, multithreaded): the reference.
    Cpu,
    /// The wgpu compute backend (f32).
    Gpu,
}

#[derive(Subcommand)]
pub enum Command {
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
        /// Parameters from a file, as a RON list of (name, value) pairs (a sweep passes its
        /// points' values this way: no value is too long for a command line).
        #[arg(long, value_name = "FILE")]
        set_file: Option<PathBuf>,
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
        /// Also time each named stage: the same steps run as separate passes, one per stage
        /// (on the GPU each its own compute pass, timed by the device), and each stage's share
        /// of them printed.
        #[arg(long)]
        profile: bool,
        /// The lattice at rest (as LIGGGHTS is measured on) or stirred (rows rebuilt as it moves).
        #[arg(long, value_enum, default_value_t = matdem_rs::bench::BenchScene::Packed)]
        scene: matdem_rs::bench::BenchScene,
        /// Switch a field stage on in the scene (repeat for several): what it costs a step.
        #[arg(long = "field", value_enum)]
        fields: Vec<matdem_rs::bench::BenchField>,
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
        vary: Vec<Vary>,
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
        #[arg(short = 'j', long, default_value_t = 1, value_parser = at_least_one)]
        jobs: usize,
        /// The most settings the --vary grid may have: each is a run.
        #[arg(long, value_name = "N", default_value_t = matdem_rs::sweep::plan::DEFAULT_MAX_POINTS, value_parser = positive::<usize>)]
        max_points: usize,
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
pub enum SweepCommand {
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
        /// The most points the sweep may have: each is a run folder and a run.
        #[arg(long, value_name = "N", default_value_t = matdem_rs::sweep::plan::DEFAULT_MAX_POINTS, value_parser = positive::<usize>)]
        max_points: usize,
    },
    /// Run the pending points (no outcome yet, or interrupted) on this machine.
    Run {
        dir: PathBuf,
        /// On this machine, in child processes (for a cluster, see `sweep slurm`).
        #[arg(long, required = true)]
        local: bool,
        /// Points run at once (they share the cores).
        #[arg(short = 'j', long, default_value_t = 1, value_parser = at_least_one)]
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
pub struct LimitArgs {
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
    /// Most memory the run's fields, masks, tables and charts may hold together: bytes, or a
    /// number with K, M, G or T (e.g. 16G) [default: half of this machine's memory].
    #[arg(long, value_name = "SIZE", value_parser = matdem_rs::memory::parse_size)]
    max_memory: Option<u64>,
}

/// A limit of at least 1.
fn positive<T: std::str::FromStr + PartialEq + From<u8>>(text: &str) -> Result<T, String> {
    match text.parse::<T>() {
        Ok(v) if v == T::from(0) => {
            Err("0 would switch the limit off; give at least 1 (or leave the option out for the default)".into())
        }
        Ok(v) => Ok(v),
        Err(_) => Err(not_a_count(text)),
    }
}

/// A count of at least 1 (processes at once): 0 would run nothing.
fn at_least_one(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(0) => Err("0 would run nothing; give at least 1".into()),
        Ok(v) => Ok(v),
        Err(_) => Err(not_a_count(text)),
    }
}

fn not_a_count(text: &str) -> String {
    if !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()) {
        format!("`{text}` is too large: give at most {}", usize::MAX)
    } else {
        format!("`{text}` is not a whole number")
    }
}

impl LimitArgs {
    pub fn resolve(&self) -> Limits {
        Limits {
            max_memory: self.max_memory.unwrap_or_else(matdem_rs::memory::default_limit),
            max_operations: self.max_operations,
            max_call_depth: self.max_call_depth as usize,
            max_string_size: self.max_string_size,
            max_array_size: self.max_array_size,
            max_map_size: self.max_map_size,
        }
    }
}
