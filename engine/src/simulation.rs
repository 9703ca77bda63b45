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
    /// Called whenever the step count reaches a multiple of its period (snapshots).
    pub observer: Option<Observer>,
    /// Set when the model runs on a GPU: the device and the pipelines for the current plan.
    #[cfg(feature = "gpu")]
    gpu: Option<GpuRunner>,
}

#[cfg(feature = "gpu")]
struct GpuRunner {
    ctx: std::sync::Arc<crate::backend::gpu::device::GpuContext>,
    prepared: Option<(PlanKey, crate::backend::gpu::GpuBackend)>,
}

/// A host callback run at every `every`-th step of the model's clock, between steps, with
/// the model as it is then; an error stops the run. Runs are cut into chunks that end on
/// those steps, which changes no result: chunk ends only check, report and observe.
pub struct Observer {
    pub every: u64,
    pub call: ObserverFn,
}

/// What an observer runs; its error message stops the run.
pub type ObserverFn = Box<dyn FnMut(&Model) -> std::result::Result<(), String>>;

/// Steps between the unbalanced-force checks of a tolerance balance.
const TOLERANCE_CHUNK: u64 = 100;

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
            observer: None,
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

    /// Puts `model` in place of the current one (a loaded checkpoint), on the same backend;
    /// prepared plans are dropped, so nothing of the old model's per-pair state carries over.
    pub fn replace_model(&mut self, model: Model) {
        self.model = model;
        self.backend = None;
        #[cfg(feature = "gpu")]
        if let Some(g) = &mut self.gpu {
            g.prepared = None;
        }
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
            let Some(o) = self.observer.as_mut().filter(|o| o.every > 0) else {
                return run_on_gpu(g, &mut self.model, steps, every, ctl, progress, sample);
            };
            // Observed runs go in pieces that end on the observer's steps; each piece brings
            // the model back from the device, which the observer then reads.
            let mut done = 0;
            while done < steps {
                let piece = (o.every - self.model.clock.step % o.every).min(steps - done);
                run_on_gpu(g, &mut self.model, piece, every, ctl, &mut |k| progress(done + k), sample).map_err(
                    |e| match e {
                        Error::Cancelled { completed_steps } => {
                            Error::Cancelled { completed_steps: done + completed_steps }
                        }
                        other => other,
                    },
                )?;
                done += piece;
                if self.model.clock.step % o.every == 0 {
                    (o.call)(&self.model).map_err(Error::Observer)?;
                }
            }
            return Ok(RunReport { steps, unbalanced_ratio: None });
        }
        let guard_every = self.model.settings.guard_every.max(1);
        let Simulation { model, backend, observer, .. } = self;
        let backend = prepared(backend, model);
        let mut samples = Vec::new();
        let mut done = 0;
        while done < steps {
            let mut chunk = guard_every.min(steps - done);
            if let Some(o) = observer.as_ref().filter(|o| o.every > 0) {
                chunk = chunk.min(o.every - model.clock.step % o.every);
            }
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
            if let Some(o) = observer.as_mut().filter(|o| o.every > 0 && model.clock.step % o.every == 0) {
                (o.call)(model).map_err(Error::Observer)?;
            }
            progress(done);
            if ctl.is_cancelled() {
                return Err(Error::Cancelled { completed_steps: done });
            }
        }
        Ok(RunReport { steps, unbalanced_ratio: None })
    }

    /// MatDEM's `balance`: lets the model settle under the current loads.
    pub fn balance(&mut self, how: Balance, ctl: &RunControl, progress: &mut dyn FnMut(u64)) -> Result<RunReport> {
        self.balance_from(how, 0, ctl, progress)
    }

    /// Continues a balance that had run `done` steps when it was cancelled, so that the
    /// steps and checks that follow are those the uncancelled balance would have made. A
    /// cancellation reports the steps done in the whole balance, earlier ones included.
    pub fn balance_from(
        &mut self,
        how: Balance,
        done: u64,
        ctl: &RunControl,
        progress: &mut dyn FnMut(u64),
    ) -> Result<RunReport> {
        let shift = |e: Error, base: u64| match e {
            Error::Cancelled { completed_steps } => Error::Cancelled { completed_steps: base + completed_steps },
            other => other,
        };
        match how {
            Balance::Steps(n) => {
                let rest = n.saturating_sub(done);
                self.run(rest, ctl, &mut |k| progress(done + k)).map_err(|e| shift(e, done))?;
                Ok(RunReport { steps: n, unbalanced_ratio: Some(self.contact_stats().unbalanced_ratio) })
            }
            Balance::Standard { rounds } => {
                let steps = (self.standard_balance_steps() as f64 * rounds).ceil() as u64;
                self.balance_from(Balance::Steps(steps), done, ctl, progress)
            }
            Balance::Tolerance { ratio, max_steps } => {
                let mut done = done;
                // Cancelled exactly at the end of a chunk, its check is still due.
                let check_due = done > 0 && (done % TOLERANCE_CHUNK == 0 || done == max_steps);
                if check_due {
                    let r = self.contact_stats().unbalanced_ratio;
                    if r < ratio || done >= max_steps {
                        return Ok(RunReport { steps: done, unbalanced_ratio: Some(r) });
                    }
                }
                while done < max_steps {
                    let chunk = (TOLERANCE_CHUNK - done % TOLERANCE_CHUNK).min(max_steps - done);
                    let offset = done;
                    self.run(chunk, ctl, &mut |k| progress(offset + k)).map_err(|e| shift(e, offset))?;
                    done += chunk;
                    let r = self.contact_stats().unbalanced_ratio;
                    if r < ratio {
                        return Ok(RunReport { steps: done, unbalanced_ratio: Some(r) });
                    }
                }
                Ok(RunReport { steps: done, unbalanced_ratio: Some(self.contact_stats().unbalanced_ratio) })
            }
        }
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

    /// The normal contact load each particle carries (N), with rows covering every contact.
    pub fn contact_loads(&mut self) -> Vec<f64> {
        self.refresh_rows();
        let plan = self.plan().clone();
        crate::status::contact_loads(&self.model, &plan)
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
    if !g.prepared.as_ref().is_some_and(|(key, _)| is_current(key, model)) {
        let backend = crate::backend::gpu::GpuBackend::prepare(g.ctx.clone(), model)?;
        g.prepared = Some((plan_key(model), backend));
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
    if !cache.as_ref().is_some_and(|(key, _)| is_current(key, model)) {
        *cache = Some((plan_key(model), CpuBackend::prepare(model)));
    }
    &mut cache.as_mut().expect("prepared above").1
}

fn plan_key(model: &Model) -> PlanKey {
    (model.revision, model.settings.clone())
}

/// Whether a backend prepared under `key` still fits the model (same revision and settings).
fn is_current((rev, settings): &PlanKey, model: &Model) -> bool {
    *rev == model.revision && *settings == model.settings
}
