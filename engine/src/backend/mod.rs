//! Where time steps run. The CPU backend is the f64 reference; the GPU backend (feature
//! `gpu`) runs the same stages as WGSL kernels in f32.
//!
//! Both implement [`Backend`]: a backend is prepared for one plan ([`Target::prepare`]),
//! advances the model a chunk of steps at a time, ending each chunk with the stability
//! guard, and brings its state back into the model when asked. The run loop around it —
//! chunks, the guard's cadence, energy sampling, observers, progress, cancellation — is
//! written once, in [`crate::simulation`]. This file is the only one outside the backends'
//! own folders that names them.

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "gpu")]
pub mod speed_test;

use crate::error::Result;
use crate::guard::StiffContact;
use crate::model::Model;
use crate::plan::StepPlan;
use crate::status::EnergySample;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

pub use cpu::{CpuBackend, StageTimes};
#[cfg(feature = "gpu")]
pub use gpu::GpuBackend;

/// Lets a host cancel a long run between steps (Ctrl-C) and watch its progress.
#[derive(Clone, Default)]
pub struct RunControl {
    pub cancel: Arc<AtomicBool>,
}

impl RunControl {
    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// Steps a model, prepared for one plan. The run loop ([`crate::simulation::run_steps`])
/// calls it once per chunk, never per step: the per-step and per-particle loops stay
/// monomorphised inside each backend.
pub trait Backend {
    /// Advances `m` by `steps` steps, passing to `sample` the energies of the steps that
    /// `sampling` picks, and ends with the stability guard: an unstable state is an
    /// [`Error::Unstable`](crate::Error::Unstable) naming the particle, with the model brought
    /// up to date first. Between [`sync`](Self::sync)s the backend may keep the state on its
    /// side (a device); the model's clock then lags until the next sync.
    fn run_chunk(
        &mut self,
        m: &mut Model,
        steps: u64,
        sampling: Sampling,
        sample: &mut dyn FnMut(EnergySample),
    ) -> Result<()>;

    /// The current contact too stiff for dt ([`crate::guard::too_stiff`]) as of the end of the
    /// last chunk, or `None`. The run loop asks after every chunk until the guard has warned;
    /// a backend that keeps its state elsewhere checks there and brings the model up to date
    /// only when it found one, so that the host can name the contact.
    fn too_stiff(&mut self, m: &mut Model) -> Result<Option<StiffContact>>;

    /// Brings the model up to date with the backend's state (nothing to do where the model
    /// is the state), before an observer reads it and at the end of a run.
    fn sync(&mut self, m: &mut Model) -> Result<()>;

    /// Heap bytes of the backend's own buffers (on a GPU: the device buffers of the last run).
    fn bytes(&self) -> usize;
}

/// Which steps of a chunk report their energies: those whose index in the run (`first` is
/// the index of the chunk's first step) is a multiple of `every`; none when `every` is 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sampling {
    pub every: u64,
    pub first: u64,
}

impl Sampling {
    /// No step is sampled.
    pub const NONE: Sampling = Sampling { every: 0, first: 0 };

    /// Whether the chunk's `k`-th step (0-based) is sampled.
    #[inline]
    pub fn at(&self, k: u64) -> bool {
        self.every > 0 && (self.first + k).is_multiple_of(self.every)
    }

    /// Steps from the chunk's `k`-th step to the next sampled one after it (`u64::MAX` when
    /// none is).
    pub fn gap(&self, k: u64) -> u64 {
        if self.every > 0 {
            self.every - (self.first + k) % self.every
        } else {
            u64::MAX
        }
    }
}

/// Where a simulation's steps run.
#[derive(Clone)]
pub enum Target {
    /// The CPU reference backend, f64.
    Cpu,
    /// A GPU device, f32.
    #[cfg(feature = "gpu")]
    Gpu(Arc<gpu::device::GpuContext>),
}

impl Target {
    /// A backend for `plan` on this target; `damping` holds the particles' viscous damping
    /// coefficients ([`StepPlan::damping_coefficients`]).
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables, reason = "only the GPU reads the model here"))]
    pub fn prepare(&self, m: &Model, plan: StepPlan, damping: Vec<f64>) -> Result<Box<dyn Backend>> {
        Ok(match self {
            Target::Cpu => Box::new(CpuBackend::with_plan(plan, damping)),
            #[cfg(feature = "gpu")]
            Target::Gpu(ctx) => Box::new(GpuBackend::with_plan(ctx.clone(), m, plan, &damping)?),
        })
    }

    /// The target in words: `cpu (f64)` or `gpu (f32) on <adapter>`.
    pub fn describe(&self) -> String {
        match self {
            Target::Cpu => "cpu (f64)".to_string(),
            #[cfg(feature = "gpu")]
            Target::Gpu(ctx) => format!("gpu (f32) on {}", ctx.describe()),
        }
    }
}
