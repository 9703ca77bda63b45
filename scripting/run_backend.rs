//! Where a run's models step: `--backend cpu`, `gpu`, or `auto`. With a GPU worth measuring,
//! `auto` decides once per run, at the first run or balance of a model with particles: the
//! engine's speed test ([`matdem_engine::backend::speed_test`]) times that model on the CPU
//! and on the GPU, its line (both figures and the choice) goes to stderr and to `run.ron`,
//! and every model of the run, those made before included, steps on the faster. A resumed
//! run steps where the interrupted one did, without measuring again.

#[cfg(feature = "gpu")]
pub use matdem_engine::backend::gpu::device::GpuContext;
use matdem_engine::backend::Target;
use std::sync::Arc;

/// A build without the GPU backend (the `gpu` feature off) has no device: no GPU or `auto`
/// backend can be made, and every match on one is a match on nothing.
#[cfg(not(feature = "gpu"))]
#[derive(Debug)]
pub enum GpuContext {}

#[cfg(not(feature = "gpu"))]
impl GpuContext {
    pub fn describe(&self) -> String {
        match *self {}
    }
}

/// Where the run's models step.
#[derive(Clone, Default)]
pub enum RunBackend {
    /// The CPU backend, f64.
    #[default]
    Cpu,
    /// A GPU, f32.
    Gpu(Arc<GpuContext>),
    /// `--backend auto` with a GPU, not decided yet: models step on the CPU until the run's
    /// first run or balance measures (`api::auto_backend::settle`).
    Auto(Arc<GpuContext>),
}

impl RunBackend {
    /// The backend as `run.ron` and the resume journal word it: `cpu (f64)`,
    /// `gpu (f32) on <adapter>`, or `auto (…)` while undecided.
    pub fn describe(&self) -> String {
        match self {
            RunBackend::Cpu => "cpu (f64)".to_string(),
            RunBackend::Gpu(ctx) => format!("gpu (f32) on {}", ctx.describe()),
            RunBackend::Auto(ctx) => {
                format!("auto (cpu (f64) or gpu (f32) on {}, by a speed test at the first run)", ctx.describe())
            }
        }
    }

    /// `--backend` as the command line takes it, for runs this run starts (`run_points`):
    /// an undecided `auto` lets each decide for itself.
    pub fn cli_name(&self) -> &'static str {
        match self {
            RunBackend::Cpu => "cpu",
            RunBackend::Gpu(_) => "gpu",
            RunBackend::Auto(_) => "auto",
        }
    }

    /// Where a model made now steps (the CPU while `auto` is undecided).
    pub fn target(&self) -> Target {
        match self {
            #[cfg(feature = "gpu")]
            RunBackend::Gpu(ctx) => Target::Gpu(ctx.clone()),
            #[cfg(not(feature = "gpu"))]
            RunBackend::Gpu(ctx) => match **ctx {},
            RunBackend::Cpu | RunBackend::Auto(_) => Target::Cpu,
        }
    }

    /// A resumed `auto` run continues on the backend its journal names (`journaled`, in
    /// [`describe`](Self::describe)'s words): the CPU, or this run's GPU. Anything else is
    /// left as it is, for the resume's own check.
    pub fn resumed(self, journaled: &str) -> RunBackend {
        match (self, kind(journaled)) {
            (RunBackend::Auto(_), "cpu") => RunBackend::Cpu,
            (RunBackend::Auto(ctx), "gpu") => RunBackend::Gpu(ctx),
            (other, _) => other,
        }
    }
}

/// A backend's kind, from its words: `cpu`, `gpu` or `auto` (the first word).
pub fn kind(words: &str) -> &str {
    words.split_whitespace().next().unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_backend_kind_is_its_first_word() {
        assert_eq!(kind("gpu (f32) on llvmpipe (Vulkan, software)"), "gpu");
        assert_eq!(kind("cpu (f64)"), "cpu");
        assert_eq!(kind(""), "");
    }

    #[test]
    fn a_resumed_cpu_run_stays_on_the_cpu_whatever_the_journal_says() {
        assert_eq!(RunBackend::Cpu.resumed("gpu (f32) on x").cli_name(), "cpu");
        assert_eq!(RunBackend::Cpu.resumed("").cli_name(), "cpu");
    }
}
