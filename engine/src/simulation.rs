//! Running a model: the run loop, once for every backend — chunks that end on the guard's
//! cadence and on observer steps, energy sampling, progress, cancellation — MatDEM's
//! `balance` with its resume points, and sampled energy histories.
//!
//! A [`Backend`] only steps: it advances a chunk and ends it with the stability guard. What
//! happens between chunks is decided here, the same way on the CPU and on a GPU.

use crate::backend::{Backend, RunControl, Sampling, Target};
use crate::error::{Error, Result};
use crate::guard::{check_time_step, stiff_contact_error, GuardMode};
use crate::model::Model;
use crate::plan::StepPlan;
use crate::status::{contact_stats, kinetic_energy, potential_energies, ContactStats, Energies};

pub use crate::status::EnergySample;

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
    /// Each called whenever the step count reaches a multiple of its period (snapshots,
    /// movie frames), in this order.
    pub observers: Vec<Observer>,
    /// Where the steps run.
    target: Target,
    /// The plan for the model's current revision, and the backend prepared for it once a
    /// run needed one.
    prepared: Option<Prepared>,
    /// The guard's warning of a contact too stiff for dt (`GuardMode::Warn`): found once per
    /// model, held for the host to take (the engine writes to no terminal).
    stiff: StiffWarning,
}

/// Where the warn-mode guard's one warning stands.
#[derive(Debug, Default)]
enum StiffWarning {
    #[default]
    NotYet,
    /// Found and not yet taken by the host.
    Held(Box<Error>),
    Taken,
}

/// A plan and what was derived from it for one revision of the model.
struct Prepared {
    key: PlanKey,
    plan: StepPlan,
    /// Each particle's viscous damping coefficient, fixed with the plan.
    damping: Vec<f64>,
    backend: Option<Box<dyn Backend>>,
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
type PlanKey = (u64, crate::model::Settings, crate::effects::EffectSettings);

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
        Simulation { model, observers: Vec::new(), target: Target::Cpu, prepared: None, stiff: StiffWarning::NotYet }
    }

    /// A simulation whose runs step on the GPU device `ctx` (f32); observers (energies,
    /// contact statistics, scripts' arrays) read the model, which each run brings up to date.
    #[cfg(feature = "gpu")]
    pub fn with_gpu(model: Model, ctx: std::sync::Arc<crate::backend::gpu::device::GpuContext>) -> Self {
        Self::with_target(model, Target::Gpu(ctx))
    }

    /// A simulation whose runs step on `target`.
    pub fn with_target(model: Model, target: Target) -> Self {
        Simulation { target, ..Self::new(model) }
    }

    /// Moves the simulation to `target` (a host's `--backend auto` decided where its run
    /// steps): the model is brought up to date from the backend it leaves, whose prepared
    /// state is dropped; the plan stays. Later runs prepare a backend on `target`.
    pub fn set_target(&mut self, target: Target) -> Result<()> {
        if let Some(mut backend) = self.prepared.as_mut().and_then(|p| p.backend.take()) {
            backend.sync(&mut self.model)?;
        }
        self.target = target;
        Ok(())
    }

    /// Puts `model` in place of the current one (a loaded checkpoint), on the same backend;
    /// prepared plans are dropped, so nothing of the old model's per-pair state carries over.
    pub fn replace_model(&mut self, model: Model) {
        self.model = model;
        self.prepared = None;
        self.stiff = StiffWarning::NotYet;
    }

    /// The warn-mode guard's warning (a contact too stiff for dt, `GuardMode::Warn`) once it
    /// was found, for the host to show; it is given once per model, so later calls and later
    /// runs return `None`.
    pub fn take_warning(&mut self) -> Option<Error> {
        match std::mem::take(&mut self.stiff) {
            StiffWarning::Held(e) => {
                self.stiff = StiffWarning::Taken;
                Some(*e)
            }
            other => {
                self.stiff = other;
                None
            }
        }
    }

    /// The backend in words: `cpu (f64)` or `gpu (f32) on <adapter>`.
    pub fn backend_name(&self) -> String {
        self.target.describe()
    }

    /// The plan for the model as it is now.
    pub fn plan(&mut self) -> &StepPlan {
        &prepared(&mut self.prepared, &self.model).plan
    }

    /// The plan in words, as this simulation's backend runs it (the pore network's bytes are
    /// the GPU's f32 buffers on the GPU).
    pub fn plan_text(&mut self) -> String {
        let gpu = !matches!(self.target, Target::Cpu);
        self.plan().on(gpu).to_string()
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
        crate::effects::periodic::check_scene(&self.model)?;
        let Simulation { model, observers, target, prepared: cache, stiff } = self;
        let p = prepared(cache, model);
        let backend = match &mut p.backend {
            Some(b) => b,
            slot => {
                crate::guard::check_coincident(model)?;
                slot.insert(target.prepare(model, p.plan.clone(), p.damping.clone())?)
            }
        };
        run_loop(backend.as_mut(), model, observers, stiff, steps, every, ctl, progress, sample)
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
                let check_due = done > 0 && (done.is_multiple_of(TOLERANCE_CHUNK) || done == max_steps);
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
        self.prepared.as_ref().and_then(|p| p.backend.as_ref()).map_or(0, |b| b.bytes())
    }

    /// Energies now (kinetic from the stored half-step velocities).
    pub fn energies(&mut self) -> Energies {
        self.refresh_rows();
        let plan = &prepared(&mut self.prepared, &self.model).plan;
        let mut e = potential_energies(&self.model, plan);
        e.kinetic = kinetic_energy(&self.model);
        e
    }

    pub fn contact_stats(&mut self) -> ContactStats {
        self.refresh_rows();
        let plan = &prepared(&mut self.prepared, &self.model).plan;
        contact_stats(&self.model, plan)
    }

    /// The normal contact load each particle carries (N), with rows covering every contact.
    pub fn contact_loads(&mut self) -> Vec<f64> {
        self.refresh_rows();
        let plan = &prepared(&mut self.prepared, &self.model).plan;
        crate::status::contact_loads(&self.model, plan)
    }

    /// Every contact and bond as the model holds them now, with each element's force and
    /// torque sums ([`crate::analysis::contact_list`]), the rows rebuilt first if they do not
    /// cover the current positions.
    pub fn contact_list(&mut self) -> crate::analysis::ContactList {
        self.refresh_rows();
        let plan = &prepared(&mut self.prepared, &self.model).plan;
        crate::analysis::contact_list(&self.model, plan)
    }

    /// Rebuilds the neighbour rows if they do not cover the current positions (never built,
    /// particles added, or drifted past half the skin), so observers see every contact.
    fn refresh_rows(&mut self) {
        use crate::neighbours::{is_stale, rebuild};
        if is_stale(&self.model.contacts, &self.model.particles.pos, self.model.effects.periodic.cell.as_ref()) {
            rebuild(&mut self.model);
        }
    }
}

/// Runs `steps` steps of `model` on a backend prepared for its plan: the loop of
/// [`Simulation::run_sampled`] (without an observer), for programs and tests that hold a
/// backend of their own. Checks the time step first; an empty model runs no step. A
/// warn-mode guard goes on past a contact too stiff for dt without keeping the warning
/// (a [`Simulation`] keeps it: [`Simulation::take_warning`]).
pub fn run_steps(
    backend: &mut dyn Backend,
    model: &mut Model,
    steps: u64,
    every: u64,
    ctl: &RunControl,
    progress: &mut dyn FnMut(u64),
    sample: &mut dyn FnMut(EnergySample),
) -> Result<RunReport> {
    if model.is_empty() {
        return Ok(RunReport { steps: 0, unbalanced_ratio: None });
    }
    check_time_step(model)?;
    run_loop(backend, model, &mut [], &mut StiffWarning::NotYet, steps, every, ctl, progress, sample)
}

/// The run loop. Chunks end every `guard_every` steps of the run (where the backend's guard
/// checks the state), on each observer's steps of the model's clock, and at the end; each
/// chunk end also compares dt with the stiffest current contact (stop, or hold a warning
/// when none was found yet and the model's guard mode is `warn`); between chunks come
/// the observers whose step it is (in order, with the model brought up to date once), `progress(done)`, and the cancellation
/// check, which also brings the model up to date. Energies of every `every`-th step of the
/// run go to `sample`.
#[allow(clippy::too_many_arguments, reason = "the run loop's inputs, each used once; a struct would only rename them")]
fn run_loop(
    backend: &mut dyn Backend,
    model: &mut Model,
    observers: &mut [Observer],
    stiff: &mut StiffWarning,
    steps: u64,
    every: u64,
    ctl: &RunControl,
    progress: &mut dyn FnMut(u64),
    sample: &mut dyn FnMut(EnergySample),
) -> Result<RunReport> {
    let guard_every = model.settings.guard_every.max(1);
    // A change of gravity or of the water table since the last run is work done on the model
    // where it stands now (body_potential).
    model.book_body_work();
    // A period of 0 observes nothing.
    let active = |o: &&mut Observer| o.every > 0;
    // The clock at the run's start: a backend that keeps the state on a device advances the
    // model's clock only when it syncs.
    let step0 = model.clock.step;
    let mut done = 0;
    while done < steps {
        let mut chunk = (guard_every - done % guard_every).min(steps - done);
        for o in observers.iter_mut().filter(active) {
            chunk = chunk.min(o.every - (step0 + done) % o.every);
        }
        backend.run_chunk(model, chunk, Sampling { every, first: done }, sample)?;
        done += chunk;
        if matches!(stiff, StiffWarning::NotYet) {
            if let Some(c) = backend.too_stiff(model)? {
                let e = stiff_contact_error(model, &c);
                match model.settings.guard {
                    GuardMode::Stop => return Err(e),
                    GuardMode::Warn => *stiff = StiffWarning::Held(Box::new(e)),
                }
            }
        }
        let mut synced = false;
        for o in observers.iter_mut().filter(active).filter(|o| (step0 + done).is_multiple_of(o.every)) {
            if !synced {
                backend.sync(model)?;
                synced = true;
            }
            (o.call)(model).map_err(Error::Observer)?;
        }
        progress(done);
        if ctl.is_cancelled() {
            backend.sync(model)?;
            return Err(Error::Cancelled { completed_steps: done });
        }
    }
    backend.sync(model)?;
    Ok(RunReport { steps, unbalanced_ratio: None })
}

/// The plan (and what derives from it) for the model's current revision, rebuilt when it
/// changed; the backend prepared for an older plan goes with it.
fn prepared<'a>(cache: &'a mut Option<Prepared>, model: &Model) -> &'a mut Prepared {
    if !cache.as_ref().is_some_and(|p| is_current(&p.key, model)) {
        let plan = StepPlan::build(model);
        let damping = plan.damping_coefficients(model);
        *cache = Some(Prepared { key: plan_key(model), plan, damping, backend: None });
    }
    cache.as_mut().expect("prepared above")
}

fn plan_key(model: &Model) -> PlanKey {
    (model.revision, model.settings.clone(), model.effects.settings())
}

/// Whether a plan prepared under `key` still fits the model (same revision and settings).
fn is_current((rev, settings, effects): &PlanKey, model: &Model) -> bool {
    *rev == model.revision && *settings == model.settings && model.effects.settings_are(effects)
}
