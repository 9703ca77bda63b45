//! Running a model: prepared plans, runs of many steps with periodic stability checks,
//! MatDEM's `balance`, and sampled energy histories.

use crate::backend::cpu::CpuBackend;
use crate::backend::RunControl;
use crate::error::{Error, Result};
use crate::guard::{check_state, check_time_step};
use crate::model::Model;
use crate::plan::StepPlan;
use crate::status::{contact_stats, kinetic_energy, potential_energies, ContactStats, Energies};

/// One energy sample of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergySample {
    pub step: u64,
    pub time: f64,
    pub energies: Energies,
}

/// How long `balance` runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Balance {
    /// A fixed number of steps.
    Steps(u64),
    /// MatDEM's standard balance: about 50 steps per element along the longest side,
    /// repeated `rounds` times.
    Standard { rounds: f64 },
    /// Until the unbalanced force ratio falls under `ratio` (checked every 100 steps), or
    /// `max_steps` have run.
    Tolerance { ratio: f64, max_steps: u64 },
}

/// A model and the backend that steps it. The plan is rebuilt when the model changes.
pub struct Simulation {
    pub model: Model,
    backend: Option<(PlanKey, CpuBackend)>,
    /// Set when the model runs on a GPU: the device and the pipelines for the current plan.
    #[cfg(feature = "gpu")]
    gpu: Option<GpuRunner>,
}

#[cfg(feature = "gpu")]
struct GpuRunner {
    ctx: std::sync::Arc<crate::backend::gpu::device::GpuContext>,
    prepared: Option<(PlanKey, crate::backend::gpu::GpuBackend)>,
}

/// What a prepared plan depends on.
type PlanKey = (u64, crate::model::Settings);

/// What a run did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunReport {
    pub steps: u64,
    /// Unbalanced force ratio at the end (balance runs only).
    pub unbalanced_ratio: Option<f64>,
}

impl Simulation {
    /// A simulation on the CPU backend (f64).
    pub fn new(model: Model) -> Self {
        Simulation {
            model,
            backend: None,
            #[cfg(feature = "gpu")]
            gpu: None,
        }
    }

    /// A simulation whose runs step on the GPU device `ctx` (f32); observers (energies,
    /// contact statistics, scripts' arrays) read the model, which each run brings up to date.
    #[cfg(feature = "gpu")]
    pub fn with_gpu(model: Model, ctx: std::sync::Arc<crate::backend::gpu::device::GpuContext>) -> Self {
        Simulation { gpu: Some(GpuRunner { ctx, prepared: None }), ..Self::new(model) }
    }

    /// The backend in words: `cpu (f64)` or `gpu (f32) on <adapter>`.
    pub fn backend_name(&self) -> String {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu {
            return format!("gpu (f32) on {}", g.ctx.describe());
        }
        "cpu (f64)".to_string()
    }

    /// The plan for the model as it is now.
    pub fn plan(&mut self) -> &StepPlan {
        &prepared(&mut self.backend, &self.model).plan
    }

    /// Runs `steps` steps, checking stability every `guard_every` steps and honouring
    /// cancellation; `progress(done)` is called between chunks.
    pub fn run(&mut self, steps: u64, ctl: &RunControl, progress: &mut dyn FnMut(u64)) -> Result<RunReport> {
        self.run_sampled(steps, 0, ctl, progress, &mut |_| {})
    }

    /// As [`run`](Self::run), also passing energies every `every` steps (0 = never) to `sample`.
    pub fn run_sampled(
        &mut self,
        steps: u64,
        every: u64,
        ctl: &RunControl,
        progress: &mut dyn FnMut(u64),
        sample: &mut dyn FnMut(EnergySample),
    ) -> Result<RunReport> {
        if self.model.is_empty() {
            return Ok(RunReport { steps: 0, unbalanced_ratio: None });
        }
        check_time_step(&self.model)?;
        #[cfg(feature = "gpu")]
        if let Some(g) = &mut self.gpu {
            return run_on_gpu(g, &mut self.model, steps, every, ctl, progress, sample);
        }
        let guard_every = self.model.settings.guard_every.max(1);
        let Simulation { model, backend, .. } = self;
        let backend = prepared(backend, model);
        let mut samples = Vec::new();
        let mut done = 0;
        while done < steps {
            let chunk = guard_every.min(steps - done);
            // Step a chunk on a pool thread: the stages' parallel loops then join within
            // the pool instead of waking it from outside several times per step.
            rayon::scope(|_| {
                for k in done..done + chunk {
                    let observe = every > 0 && k % every == 0;
                    let (step, time) = (model.clock.step, model.clock.time);
                    if let Some(energies) = backend.step(model, observe) {
                        samples.push(EnergySample { step, time, energies });
                    }
                }
            });
            done += chunk;
            samples.drain(..).for_each(&mut *sample);
            check_state(model)?;
            progress(done);
            if ctl.is_cancelled() {
                return Err(Error::Cancelled { completed_steps: done });
            }
        }
        Ok(RunReport { steps, unbalanced_ratio: None })
    }

    /// MatDEM's `balance`: lets the model settle under the current loads.
    pub fn balance(&mut self, how: Balance, ctl: &RunControl, progress: &mut dyn FnMut(u64)) -> Result<RunReport> {
        let steps = match how {
            Balance::Steps(n) => n,
            Balance::Standard { rounds } => (self.standard_balance_steps() as f64 * rounds).ceil() as u64,
            Balance::Tolerance { ratio, max_steps } => {
                let mut done = 0;
                while done < max_steps {
                    let chunk = 100.min(max_steps - done);
                    let offset = done;
                    self.run(chunk, ctl, &mut |k| progress(offset + k))?;
                    done += chunk;
                    let r = self.contact_stats().unbalanced_ratio;
                    if r < ratio {
                        return Ok(RunReport { steps: done, unbalanced_ratio: Some(r) });
                    }
                }
                return Ok(RunReport { steps: done, unbalanced_ratio: Some(self.contact_stats().unbalanced_ratio) });
            }
        };
        let mut rep = self.run(steps, ctl, progress)?;
        rep.unbalanced_ratio = Some(self.contact_stats().unbalanced_ratio);
        Ok(rep)
    }

    /// Steps of one standard balance: 50 per element along the longest side (at least 500).
    pub fn standard_balance_steps(&self) -> u64 {
        let p = &self.model.particles;
        if p.is_empty() {
            return 0;
        }
        let (mut lo, mut hi) = (p.pos[0], p.pos[0]);
        for x in &p.pos {
            lo = lo.inf(x);
            hi = hi.sup(x);
        }
        let longest = (hi - lo).max();
        let d = 2.0 * self.model.mean_radius();
        ((50.0 * (longest / d + 1.0)) as u64).max(500)
    }

    /// Heap bytes of the prepared backend's own buffers (0 before the first run); on the GPU
    /// the bytes of all device buffers.
    pub fn backend_bytes(&self) -> usize {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu {
            return g.prepared.as_ref().map_or(0, |(_, b)| b.device_bytes() as usize);
        }
        self.backend.as_ref().map_or(0, |(_, b)| b.scratch_bytes())
    }

    /// Energies now (kinetic from the stored half-step velocities).
    pub fn energies(&mut self) -> Energies {
        self.refresh_rows();
        let plan = self.plan().clone();
        let mut e = potential_energies(&self.model, &plan);
        e.kinetic = kinetic_energy(&self.model);
        e
    }

    pub fn contact_stats(&mut self) -> ContactStats {
        self.refresh_rows();
        let plan = self.plan().clone();
        contact_stats(&self.model, &plan)
    }

    /// Rebuilds the neighbour rows if they do not cover the current positions (never built,
    /// particles added, or drifted past half the skin), so observers see every contact.
    fn refresh_rows(&mut self) {
        use crate::backend::cpu::neighbours::{is_stale, rebuild};
        if is_stale(&self.model.contacts, &self.model.particles.pos) {
            rebuild(&mut self.model);
        }
    }
}

/// A run on the GPU, with the pipelines prepared for the model's current revision.
#[cfg(feature = "gpu")]
fn run_on_gpu(
    g: &mut GpuRunner,
    model: &mut Model,
    steps: u64,
    every: u64,
    ctl: &RunControl,
    progress: &mut dyn FnMut(u64),
    sample: &mut dyn FnMut(EnergySample),
) -> Result<RunReport> {
    let fresh = |(rev, settings): &PlanKey| *rev == model.revision && *settings == model.settings;
    if !g.prepared.as_ref().is_some_and(|(key, _)| fresh(key)) {
        let backend = crate::backend::gpu::GpuBackend::prepare(g.ctx.clone(), model)?;
        g.prepared = Some(((model.revision, model.settings.clone()), backend));
    }
    let backend = &mut g.prepared.as_mut().expect("prepared above").1;
    let plan = backend.plan.clone();
    backend.run(model, steps, every, ctl, progress, &mut |m| {
        let mut energies = potential_energies(m, &plan);
        energies.kinetic = kinetic_energy(m);
        sample(EnergySample { step: m.clock.step, time: m.clock.time, energies });
    })?;
    Ok(RunReport { steps, unbalanced_ratio: None })
}

/// The backend prepared for the model's current revision (rebuilt when it changed).
fn prepared<'a>(cache: &'a mut Option<(PlanKey, CpuBackend)>, model: &Model) -> &'a mut CpuBackend {
    let fresh = |(rev, settings): &PlanKey| *rev == model.revision && *settings == model.settings;
    if !cache.as_ref().is_some_and(|(key, _)| fresh(key)) {
        *cache = Some(((model.revision, model.settings.clone()), CpuBackend::prepare(model)));
    }
    &mut cache.as_mut().expect("prepared above").1
}
