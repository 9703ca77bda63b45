//! `matdem-rs bench`: times the standard lattice scene ([`matdem_engine::bench`]) and prints
//! throughput, contacts, memory and the machine, as text or as one JSON object.

use crate::run_backend::GpuContext;
#[cfg(feature = "gpu")]
use matdem_engine::backend::gpu::profile::{GpuProfile, ProfileClock};
#[cfg(feature = "gpu")]
use matdem_engine::bench::profile_gpu;
use matdem_engine::bench::{profile, run, BenchReport, LatticeScene, StageProfile};
use matdem_engine::Simulation;
use std::sync::Arc;

/// Which backend ran, and on what.
struct Backend {
    name: &'static str,
    device: String,
}
use std::fmt::Write as _;

/// What to measure.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// About this many particles (the standard 20 × 20 × 50 scene when `None`).
    pub particles: Option<usize>,
    pub warmup: u64,
    pub steps: u64,
    pub json: bool,
    /// Also time each named stage in separate passes.
    pub profile: bool,
    /// Bench this GPU instead of the CPU backend.
    pub gpu: Option<Arc<GpuContext>>,
    /// Field stages switched on in the scene, so that a run shows what each costs a step.
    pub fields: Vec<BenchField>,
    /// The lattice at rest (as LIGGGHTS is measured on) or stirred.
    pub scene: BenchScene,
}

/// Which lattice `bench` times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum BenchScene {
    /// The standard lattice at rest, as LIGGGHTS is measured on.
    #[default]
    Packed,
    /// The same lattice with every grain started at up to ±0.5 m/s a component: the grains
    /// collide and the neighbour rows are rebuilt every few hundred steps, as in a deposition.
    Stirred,
    /// As many particles in 2D: one square layer in the x–z plane (20:50), the model made 2D
    /// (y and spin about x and z held): what a 2D scene costs against the 3D one.
    Planar,
}

/// A field stage `bench --field` switches on in the standard scene, every step (a field step
/// of one mechanical step: its most expensive setting).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchField {
    /// Heat conduction (k = 1 W/(m·K), c = 800 J/(kg·K), no expansion).
    Heat,
    /// Moisture diffusion (α_w = 1e-3 kg/(m²·s), ω = 0.2, no tables).
    Moisture,
    /// A water table at half the lattice's height (buoyancy, ρ_f = 1000 kg/m³).
    Water,
}

impl BenchField {
    fn name(self) -> &'static str {
        match self {
            BenchField::Heat => "heat (k 1 W/(m·K), c 800 J/(kg·K), every step)",
            BenchField::Moisture => "moisture (α_w 1e-3 kg/(m²·s), ω 0.2, every step)",
            BenchField::Water => "water table at half height (ρ_f 1000 kg/m³)",
        }
    }

    /// Switches the field on in the bench scene's model.
    fn apply(self, m: &mut matdem_engine::Model, s: &LatticeScene) -> matdem_engine::Result<()> {
        match self {
            BenchField::Heat => {
                m.enable_heat();
                let props = matdem_engine::effects::conduction::ThermalProps {
                    conductivity: 1.0,
                    specific_heat: 800.0,
                    expansion: 0.0,
                };
                m.set_thermal_material("bench", props)
            }
            BenchField::Moisture => {
                m.effects.moisture.settings.initial = 0.2;
                m.enable_moisture();
                m.set_moisture_material("bench", 1e-3)
            }
            BenchField::Water => {
                m.settings.water.level = Some(0.5 * s.nz as f64 * s.spacing);
                Ok(())
            }
        }
    }
}

/// Builds and times the scene; returns what to print on stdout.
pub fn run_bench(cfg: &BenchConfig) -> Result<String, String> {
    let scene = match cfg.particles {
        Some(0) => return Err("error: --particles must be at least 1".into()),
        Some(n) => LatticeScene::with_particles(n),
        None => LatticeScene::default(),
    };
    let scene = match cfg.scene {
        BenchScene::Packed => scene,
        BenchScene::Stirred => scene.stirred(),
        BenchScene::Planar => scene.planar(),
    };
    if cfg.steps == 0 {
        return Err("error: --steps must be at least 1".into());
    }
    let mut model = scene.build().map_err(|e| format!("error: building the bench scene: {e}"))?;
    for f in &cfg.fields {
        f.apply(&mut model, &scene).map_err(|e| format!("error: switching on {}: {e}", f.name()))?;
    }
    let failed = |e: matdem_engine::Error| format!("error: the profiled run failed: {e}");
    let (profile, gpu_profile) = match (cfg.profile, &cfg.gpu) {
        (false, _) => (None, None),
        (true, None) => (Some(profile(&model, cfg.warmup, cfg.steps).map_err(failed)?), None),
        (true, Some(ctx)) => (None, Some(gpu_profile(&model, ctx, cfg).map_err(failed)?)),
    };
    let sim = match &cfg.gpu {
        Some(ctx) => on_gpu(model, ctx),
        None => Simulation::new(model),
    };
    let (report, _) = run(sim, cfg.warmup, cfg.steps).map_err(|e| format!("error: the bench run failed: {e}"))?;
    let device = match &cfg.gpu {
        Some(ctx) => ctx.describe(),
        None => cpu_model(),
    };
    let backend = Backend { name: if cfg.gpu.is_some() { "gpu" } else { "cpu" }, device };
    let mut out = if cfg.json {
        json(&scene, &report, &backend, &cfg.fields, gpu_profile.as_ref())
    } else {
        text(&scene, &report, &backend, &cfg.fields)
    };
    if let (Some(p), false) = (&profile, cfg.json) {
        out.push_str(&profile_text(p));
    }
    if let (Some(p), false) = (&gpu_profile, cfg.json) {
        out.push_str(&gpu_profile_text(p));
    }
    Ok(out)
}

/// Each stage's time on the GPU ([`matdem_engine::bench::profile_gpu`]).
#[cfg(feature = "gpu")]
fn gpu_profile(
    model: &matdem_engine::Model,
    ctx: &Arc<GpuContext>,
    cfg: &BenchConfig,
) -> matdem_engine::Result<GpuProfile> {
    profile_gpu(model, ctx.clone(), cfg.warmup, cfg.steps)
}

#[cfg(feature = "gpu")]
fn on_gpu(model: matdem_engine::Model, ctx: &Arc<GpuContext>) -> Simulation {
    Simulation::with_gpu(model, ctx.clone())
}

/// A build without the GPU backend has no device, so no GPU profile either.
#[cfg(not(feature = "gpu"))]
enum GpuProfile {}

#[cfg(not(feature = "gpu"))]
fn gpu_profile(_: &matdem_engine::Model, ctx: &Arc<GpuContext>, _: &BenchConfig) -> matdem_engine::Result<GpuProfile> {
    match **ctx {}
}

#[cfg(not(feature = "gpu"))]
fn on_gpu(_: matdem_engine::Model, ctx: &Arc<GpuContext>) -> Simulation {
    match **ctx {}
}

#[cfg(not(feature = "gpu"))]
fn gpu_profile_text(p: &GpuProfile) -> String {
    match *p {}
}

#[cfg(not(feature = "gpu"))]
fn gpu_profile_json(p: &GpuProfile) -> String {
    match *p {}
}

/// Each named stage's share of a step, from separate passes.
fn profile_text(p: &StageProfile) -> String {
    let mut o = String::new();
    let total = p.total();
    let _ = writeln!(
        o,
        "profile: {} steps as separate passes, one per named stage, {:.3} s ({:.3} ms a step; the fused pass \
         took {:.3} s for the same steps from the same start):",
        p.steps,
        total,
        1e3 * total / p.steps.max(1) as f64,
        p.fused_seconds
    );
    for (name, t) in &p.stages {
        let share = if total > 0.0 { 100.0 * t / total } else { 0.0 };
        let _ = writeln!(o, "  {name:<15} {share:5.1} %  {:.4} ms a step", 1e3 * t / p.steps.max(1) as f64);
    }
    let _ = writeln!(o, "  (heat: booked inside contact_forces, wall_forces and integrate, its time theirs)");
    o
}

/// Each stage's time on the device, the bytes it binds and the bandwidth that makes.
#[cfg(feature = "gpu")]
fn gpu_profile_text(p: &GpuProfile) -> String {
    let mut o = String::new();
    let per_step = |x: f64| x / p.steps.max(1) as f64;
    let clock = match p.clock {
        ProfileClock::Timestamps { period } => format!("timestamp queries, {period} ns a tick"),
        ProfileClock::Host => "the host's clock around each pass's submission and wait: this adapter has no                                timestamp queries, so each pass also counts its submission"
            .to_string(),
    };
    let total = p.total();
    let _ = writeln!(
        o,
        "profile: {} steps with each stage in its own pass, {:.3} ms a step ({clock}); {} steps as a run encodes \
         them (up to 64 in one pass), in turn with those: {:.3} ms a step",
        p.steps,
        1e3 * per_step(total),
        p.batched_steps,
        1e3 * p.batched_seconds / p.batched_steps.max(1) as f64
    );
    let nominal = p.nominal_bandwidth;
    let _ = writeln!(
        o,
        "  {:<24} {:>6} {:>10} {:>11} {:>16} {:>9}{}",
        "stage",
        "share",
        "ms a step",
        "dispatches",
        "bytes bound/p·s",
        "GB/s",
        if nominal.is_some() { "  of nominal" } else { "" }
    );
    let n = p.particles.max(1) as f64;
    for s in &p.stages {
        let share = if total > 0.0 { 100.0 * s.seconds / total } else { 0.0 };
        let rate = if s.seconds > 0.0 { s.bytes as f64 / s.seconds } else { 0.0 };
        let of = nominal.map(|bw| format!("  {:>8.1} %", 100.0 * rate / bw)).unwrap_or_default();
        let _ = writeln!(
            o,
            "  {:<24} {share:5.1} % {:>10.4} {:>11.2} {:>16.0} {:>9.1}{of}",
            s.name,
            1e3 * per_step(s.seconds),
            per_step(s.dispatches as f64),
            per_step(s.bytes as f64) / n,
            rate / 1e9
        );
    }
    let _ = writeln!(
        o,
        "  a run's step: {:.2} dispatches, {:.3} submissions (one a batch for the steps, one for the counters' \
         read, the row builds); nominal bandwidth {}",
        p.dispatches_per_step,
        p.submissions_per_step,
        nominal.map_or("not known for this adapter".to_string(), |bw| format!("{:.2} TB/s", bw / 1e12))
    );
    o
}

/// The CPU's model name from /proc/cpuinfo (Linux), else the architecture.
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

fn scene_line(s: &LatticeScene) -> String {
    let mut line = format!(
        "lattice {}×{}×{} = {} spheres, d = {} mm at spacing {} mm, ρ = {} kg/m³, Hertz–Mindlin E = {} MPa ν = {}, \
         μ = {}, e = {}, {} plane walls, gravity {} m/s², rotation {}, dt = {:e} s",
        s.nx,
        s.ny,
        s.nz,
        s.particles(),
        s.diameter * 1e3,
        s.spacing * 1e3,
        s.density,
        s.young / 1e6,
        s.poisson,
        s.friction,
        s.restitution,
        if s.planar { 3 } else { 5 },
        s.gravity,
        if s.rotation { "on" } else { "off" },
        s.dt
    );
    if s.stir > 0.0 {
        let _ = write!(line, ", stirred: start velocities within ±{} m/s a component", s.stir);
    }
    if s.planar {
        line.push_str(", 2D (x–z plane; y and spin about x, z held)");
    }
    line
}

fn text(s: &LatticeScene, r: &BenchReport, b: &Backend, fields: &[BenchField]) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "scene: {}", scene_line(s));
    if !fields.is_empty() {
        let names: Vec<&str> = fields.iter().map(|f| f.name()).collect();
        let _ = writeln!(o, "fields: {}", names.join(", "));
    }
    if b.name == "gpu" {
        let _ = writeln!(o, "backend: gpu (f32) on {}", b.device);
    } else {
        let _ = writeln!(o, "backend: cpu (f64), {} thread(s) on {}", r.threads, b.device);
    }
    let _ = writeln!(o, "steps: {} warm-up + {} timed in {:.3} s", r.warmup, r.steps, r.seconds);
    let _ = writeln!(o, "particle-steps per second: {:.4e}", r.particle_steps_per_s);
    let _ = writeln!(
        o,
        "contacts per particle: {:.3} (particle–particle, each pair at both ends, walls not counted: \
         as LIGGGHTS' compute contact/atom); wall contacts per particle: {:.3}",
        r.contacts_per_particle, r.wall_contacts_per_particle
    );
    let _ = writeln!(
        o,
        "memory per particle: {:.0} bytes ({})",
        r.bytes_per_particle,
        if b.name == "gpu" {
            "device buffers: particle lanes, heat ledger, neighbour rows in slots, pair and wall contact state with dashpot forces, cell list"
        } else {
            "particle lanes, neighbour rows, pair and wall contact state, contact scratch"
        }
    );
    let sets: Vec<String> = r
        .lane_sets
        .iter()
        .map(|s| format!("{} {} B ({})", s.stage, s.bytes_per_particle, s.lanes.join(", ")))
        .collect();
    let _ = writeln!(
        o,
        "plan lanes per particle (f64, as the CPU allocates them): {} = {} B",
        sets.join(" + "),
        r.lane_sets.iter().map(|s| s.bytes_per_particle).sum::<usize>()
    );
    o
}

/// The GPU profile as a JSON object: the clock, each stage's seconds, bytes and dispatches
/// over the profiled steps, the batched time, a run's dispatches and submissions a step.
#[cfg(feature = "gpu")]
fn gpu_profile_json(p: &GpuProfile) -> String {
    let stages: Vec<String> = p
        .stages
        .iter()
        .map(|s| {
            format!(
                "{{\"name\":{},\"seconds\":{},\"bytes\":{},\"dispatches\":{}}}",
                json_str(s.name),
                json_num(s.seconds),
                s.bytes,
                s.dispatches
            )
        })
        .collect();
    let clock = match p.clock {
        ProfileClock::Timestamps { .. } => "timestamps",
        ProfileClock::Host => "host",
    };
    format!(
        "{{\"clock\":{},\"steps\":{},\"stages\":[{}],\"batched_steps\":{},\"batched_seconds\":{},\"dispatches_per_step\":{},\
         \"submissions_per_step\":{},\"nominal_bandwidth\":{}}}",
        json_str(clock),
        p.steps,
        stages.join(","),
        p.batched_steps,
        json_num(p.batched_seconds),
        json_num(p.dispatches_per_step),
        json_num(p.submissions_per_step),
        p.nominal_bandwidth.map_or("null".to_string(), json_num)
    )
}

fn json_num(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".into()
    }
}

fn json_str(s: &str) -> String {
    let mut o = String::with_capacity(s.len() + 2);
    o.push('"');
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            c if (c as u32) < 0x20 => {
                let _ = write!(o, "\\u{:04x}", c as u32);
            }
            c => o.push(c),
        }
    }
    o.push('"');
    o
}

fn json(s: &LatticeScene, r: &BenchReport, b: &Backend, on: &[BenchField], profile: Option<&GpuProfile>) -> String {
    let on: Vec<String> = on.iter().map(|f| json_str(&format!("{f:?}").to_lowercase())).collect();
    let fields: Vec<(&str, String)> = vec![
        ("backend", json_str(b.name)),
        ("device", json_str(&b.device)),
        ("threads", r.threads.to_string()),
        (
            "scene",
            json_str(if s.planar {
                "2D lattice"
            } else if s.stir > 0.0 {
                "stirred lattice"
            } else {
                "lattice"
            }),
        ),
        ("fields", format!("[{}]", on.join(","))),
        ("nx", s.nx.to_string()),
        ("ny", s.ny.to_string()),
        ("nz", s.nz.to_string()),
        ("particles", r.particles.to_string()),
        ("warmup", r.warmup.to_string()),
        ("steps", r.steps.to_string()),
        ("seconds", json_num(r.seconds)),
        ("particle_steps_per_s", json_num(r.particle_steps_per_s)),
        ("contacts_per_particle", json_num(r.contacts_per_particle)),
        ("wall_contacts_per_particle", json_num(r.wall_contacts_per_particle)),
        ("bytes_per_particle", json_num(r.bytes_per_particle)),
        ("plan_bytes_per_particle", r.lane_sets.iter().map(|s| s.bytes_per_particle).sum::<usize>().to_string()),
    ];
    let mut fields = fields;
    if let Some(p) = profile {
        fields.push(("profile", gpu_profile_json(p)));
    }
    let body: Vec<String> = fields.iter().map(|(k, v)| format!("{}:{v}", json_str(k))).collect();
    format!("{{{}}}\n", body.join(","))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_strings_are_escaped() {
        assert_eq!(json_str("a\"b\\c\n"), r#""a\"b\\c\u000a""#);
        assert_eq!(json_num(f64::NAN), "null");
        assert_eq!(json_num(2.5e6), "2500000");
    }
}
