//! `--backend auto` decided ([`crate::run_backend`]): at the first run or balance of a model
//! with particles, the engine's speed test times that model on the CPU and on the GPU, and
//! every model of the run moves to the faster.

use super::model::ModelHandle;
use super::Host;
#[cfg(feature = "gpu")]
use crate::eoutln;
#[cfg(feature = "gpu")]
use crate::run_backend::RunBackend;
#[cfg(feature = "gpu")]
use matdem_engine::backend::speed_test::{measure, Choice};

/// Decides an undecided `auto` run at the run or balance of `d` about to start: measures
/// `d`'s model and moves every model of the run to the faster backend. Nothing happens
/// when the run is decided, or when `d` has no particles (the next run decides). A speed
/// test that could not step the scene on the CPU leaves the run undecided: the run itself
/// meets the same error and reports it.
#[cfg(feature = "gpu")]
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
    eoutln!("{line}");
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

/// Without the GPU backend a run is never undecided: nothing to settle.
#[cfg(not(feature = "gpu"))]
pub fn settle(_host: &Host, _d: &ModelHandle) -> Result<(), String> {
    Ok(())
}
