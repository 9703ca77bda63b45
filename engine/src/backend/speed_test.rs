//! `--backend auto`'s speed test, as MatDEM's `setGPU('auto')` runs `testSpeed`: the scene a
//! run is about to step is timed for a moment on the CPU backend and on a GPU, and the run
//! takes the faster. Which one wins depends on the scene as much as on the machine: a few
//! hundred particles leave a datacentre GPU idle between its synchronisations (the oedometer's
//! 237 ran 29 s on an H200 and 14 s on two CPU cores), a few hundred thousand leave the cores
//! far behind.
//!
//! Each side steps its own clone of the model from the same state, through [`Simulation`]:
//! a warm-up of [`WARMUP_STEPS`] (the GPU compiles its pipelines and uploads the model, both
//! sides build their first neighbour rows), then runs of growing length until one takes at
//! least [`TARGET_S`] or reaches [`MAX_STEPS`]; that run's rate counts. The budget: a small
//! scene costs about 2 × [`TARGET_S`] a side, plus the GPU's pipeline compilation (well
//! under a second on the CPU side); a scene whose single step takes longer than
//! [`TARGET_S`] costs a few of its steps a side. The caller's model is never touched, and
//! the inputs are the same on every call: only the timing varies.

use crate::backend::gpu::device::GpuContext;
use crate::backend::{RunControl, Target};
use crate::error::Result;
use crate::model::Model;
use crate::simulation::Simulation;
use std::sync::Arc;
use std::time::Instant;

/// Steps run before timing: the first run of a backend prepares it (pipelines, upload, rows).
pub const WARMUP_STEPS: u64 = 2;
/// The first timed run; each later one is sized from the last to take about [`TARGET_S`].
const FIRST_STEPS: u64 = 4;
/// A timed run at least this long (s) is long enough for its rate to count.
pub const TARGET_S: f64 = 0.15;
/// No timed run is longer than this many steps (a tiny scene reaches it before [`TARGET_S`]).
pub const MAX_STEPS: u64 = 10_000;
/// How much faster the GPU must be to be chosen: it steps in f32 where the CPU is the f64
/// reference, and two timings of a fraction of a second differ by some 10 % from noise
/// alone, so a near tie goes to the reference.
pub const GPU_MARGIN: f64 = 1.2;

/// Where the test says the run should step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Choice {
    Cpu,
    Gpu,
}

impl std::fmt::Display for Choice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Choice::Cpu => "cpu",
            Choice::Gpu => "gpu",
        })
    }
}

/// One backend's counted run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    pub steps: u64,
    pub seconds: f64,
    /// Particle-steps per second.
    pub rate: f64,
}

/// What the test measured and chose.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedTest {
    pub particles: usize,
    /// The CPU backend's timing; `None` for an empty model (nothing was measured).
    pub cpu: Option<Timing>,
    /// The GPU's timing, or why it could not step the scene.
    pub gpu: std::result::Result<Timing, String>,
    /// The GPU in words ([`GpuContext::describe`]).
    pub device: String,
    pub choice: Choice,
}

/// The faster backend by particle-steps per second, the GPU only when it is at least
/// [`GPU_MARGIN`] times the CPU's rate.
pub fn choose(cpu: f64, gpu: Option<f64>) -> Choice {
    match gpu {
        Some(g) if g >= GPU_MARGIN * cpu => Choice::Gpu,
        _ => Choice::Cpu,
    }
}

/// Times `model` on the CPU backend and on `ctx` and chooses (see the module's notes). An
/// empty model chooses the CPU without measuring; a GPU that fails on the scene chooses the
/// CPU and says why. An error is the scene's own, met on the CPU reference (a time step not
/// set, an unstable state): the run would meet it too, on either backend.
pub fn measure(model: &Model, ctx: Arc<GpuContext>) -> Result<SpeedTest> {
    let device = ctx.describe();
    if model.is_empty() {
        return Ok(SpeedTest {
            particles: 0,
            cpu: None,
            gpu: Err("the model is empty: nothing to measure".into()),
            device,
            choice: Choice::Cpu,
        });
    }
    let particles = model.len();
    let cpu = time(Simulation::new(model.clone()))?;
    let gpu = time(Simulation::with_target(model.clone(), Target::Gpu(ctx))).map_err(|e| e.to_string());
    let choice = choose(cpu.rate, gpu.as_ref().ok().map(|g| g.rate));
    Ok(SpeedTest { particles, cpu: Some(cpu), gpu, device, choice })
}

/// Warms `sim` up, then times runs of growing length until one is long enough.
fn time(mut sim: Simulation) -> Result<Timing> {
    let ctl = RunControl::default();
    let particles = sim.model.len() as f64;
    sim.run(WARMUP_STEPS, &ctl, &mut |_| {})?;
    let mut steps = FIRST_STEPS;
    loop {
        let started = Instant::now();
        sim.run(steps, &ctl, &mut |_| {})?;
        let seconds = started.elapsed().as_secs_f64();
        if seconds >= TARGET_S || steps >= MAX_STEPS {
            return Ok(Timing { steps, seconds, rate: particles * steps as f64 / seconds.max(1e-9) });
        }
        steps = next_steps(steps, seconds);
    }
}

/// The length of the run after one of `steps` steps that took `seconds` (< [`TARGET_S`]): a
/// little past the target, so that it is the last; at least twice `steps`, so that a run
/// too short to time still ends the loop soon; at most [`MAX_STEPS`].
fn next_steps(steps: u64, seconds: f64) -> u64 {
    let aimed = steps as f64 * 1.25 * TARGET_S / seconds.max(1e-9);
    (aimed.ceil() as u64).max(2 * steps).min(MAX_STEPS)
}

impl std::fmt::Display for SpeedTest {
    /// One line: both rates, the scene and the choice, e.g. `auto: cpu 3.1e6 particle-steps/s,
    /// gpu (NVIDIA H200 (Vulkan, hardware)) 1.2e6 on this scene (237 particles; 5000 and 800
    /// steps timed) → cpu`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Some(cpu) = self.cpu else {
            return write!(f, "auto: the model is empty, nothing to measure → {}", self.choice);
        };
        match &self.gpu {
            Ok(gpu) => {
                write!(
                    f,
                    "auto: cpu {:.1e} particle-steps/s, gpu ({}) {:.1e} on this scene ({} particles; {} and {} steps \
                     timed) → {}",
                    cpu.rate, self.device, gpu.rate, self.particles, cpu.steps, gpu.steps, self.choice
                )?;
                if self.choice == Choice::Cpu && gpu.rate > cpu.rate {
                    write!(f, " (the gpu, f32, must be {GPU_MARGIN}× as fast to be chosen over the f64 reference)")?;
                }
                Ok(())
            }
            Err(why) => write!(
                f,
                "auto: cpu {:.1e} particle-steps/s on this scene ({} particles; {} steps timed); gpu ({}) could not \
                 step it ({why}) → {}",
                cpu.rate, self.particles, cpu.steps, self.device, self.choice
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gpu_is_chosen_only_when_clearly_faster() {
        assert_eq!(choose(1e6, Some(3e6)), Choice::Gpu);
        assert_eq!(choose(1e6, Some(GPU_MARGIN * 1e6)), Choice::Gpu);
        assert_eq!(choose(1e6, Some(1.1e6)), Choice::Cpu, "a near tie goes to the f64 reference");
        assert_eq!(choose(1e6, Some(0.5e6)), Choice::Cpu);
        assert_eq!(choose(1e6, None), Choice::Cpu, "a GPU that could not step the scene");
    }

    #[test]
    fn each_timed_run_aims_past_the_target_grows_and_stops_at_the_cap() {
        assert_eq!(next_steps(4, TARGET_S / 10.0), 50, "1.25 × the target at the measured rate");
        assert_eq!(next_steps(100, 0.9 * TARGET_S), 200, "at least twice as long");
        assert_eq!(next_steps(6000, 1e-3), MAX_STEPS, "twice 6000 is past the cap");
        assert_eq!(next_steps(4, 0.0), MAX_STEPS, "a run too short to time");
    }

    fn timing(steps: u64, rate: f64) -> Timing {
        Timing { steps, seconds: 0.2, rate }
    }

    #[test]
    fn the_summary_names_both_rates_the_scene_and_the_choice() {
        let t = SpeedTest {
            particles: 237,
            cpu: Some(timing(5000, 3.1e6)),
            gpu: Ok(timing(800, 1.2e6)),
            device: "H200 (Vulkan, hardware)".into(),
            choice: Choice::Cpu,
        };
        assert_eq!(
            t.to_string(),
            "auto: cpu 3.1e6 particle-steps/s, gpu (H200 (Vulkan, hardware)) 1.2e6 on this scene (237 particles; \
             5000 and 800 steps timed) → cpu"
        );
        let close = SpeedTest { gpu: Ok(timing(800, 3.5e6)), ..t.clone() };
        assert!(close
            .to_string()
            .ends_with("→ cpu (the gpu, f32, must be 1.2× as fast to be chosen over the f64 reference)"));
        let failed = SpeedTest { gpu: Err("out of memory".into()), ..t };
        let s = failed.to_string();
        assert!(s.contains("cpu 3.1e6") && s.contains("could not step it (out of memory) → cpu"), "{s}");
    }
}
