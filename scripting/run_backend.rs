//! Where a run's models step: `--backend cpu`, `gpu`, or `auto`. With a GPU worth measuring,
//! `auto` decides once per run, at the first run or balance of a model with particles: the
//! engine's speed test ([`matdem_engine::backend::speed_test`]) times that model on the CPU
//! and on the GPU, its line (both figures and the choice) goes to stderr and to `run.ron`,
//! and every model of the run, those made before included, steps on the faster. A resumed
//! run steps where the interrupted one did, without measuring again.

use crate::api::model::ModelHandle;
use crate::api::Host;
use matdem_engine::backend::gpu::device::GpuContext;
use matdem_engine::backend::speed_test::{measure, Choice};
use matdem_engine::backend::Target;
use std::sync::Arc;

/// Where the run's models step.
#[derive(Clone, Default)]
pub enum RunBackend {
    /// The CPU backend, f64.
    #[default]
    Cpu,
    /// A GPU, f32.
    Gpu(Arc<GpuContext>),
    /// `--backend auto` with a GPU, not decided yet: models step on the CPU until
    /// [`settle`] measures.
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
            RunBackend::Gpu(ctx) => Target::Gpu(ctx.clone()),
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

/// Decides an undecided `auto` run at the run or balance of `d` about to start: measures
/// `d`'s model and moves every model of the run to the faster backend. Nothing happens
/// when the run is decided, or when `d` has no particles (the next run decides). A speed
/// test that could not step the scene on the CPU leaves the run undecided: the run itself
/// meets the same error and reports it.
pub fn settle(host: &Host, d: &ModelHandle) -> Result<(), String> {
    let ctx = match &*host.backend.borrow() {
        RunBackend::Auto(ctx) => ctx.clone(),
        _ => return Ok(()),
    };
    let test = {
        let data = d.data();
        if data.sim.model.is_empty() {
            return Ok(());
        }
        match measure(&data.sim.model, ctx.clone()) {
            Ok(t) => t,
            Err(_) => return Ok(()),
        }
    };
    let line = test.to_string();
    eprintln!("{line}");
    let chosen = match test.choice {
        Choice::Cpu => RunBackend::Cpu,
        Choice::Gpu => RunBackend::Gpu(ctx),
    };
    for model in host.models.borrow().iter().filter_map(|w| w.upgrade()) {
        model.borrow_mut().sim.set_target(chosen.target()).map_err(|e| e.to_string())?;
    }
    host.session.borrow_mut().backend = chosen.describe();
    *host.speed_test.borrow_mut() = Some(line);
    *host.backend.borrow_mut() = chosen;
    Ok(())
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
