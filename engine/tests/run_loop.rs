//! The run loop is the simulation's, written once for both backends: a host sees the same
//! observer calls (at the same steps of the model's clock, with the model up to date), the
//! same progress reports, the same sampled steps and the same cancellation on the CPU and on
//! a GPU. The GPU half skips without an adapter unless MATDEM_REQUIRE_GPU=1.

use crate::common::{damped_glass_pair, gpu, run};
use matdem_engine::backend::RunControl;
use matdem_engine::simulation::Observer;
use matdem_engine::{Error, Simulation};
use std::cell::RefCell;
use std::rc::Rc;
use std::sync::atomic::Ordering;

/// What a host saw of one run.
#[derive(Debug, PartialEq)]
struct Trace {
    /// The clock step the observer saw at each call.
    observed: Vec<u64>,
    progress: Vec<u64>,
    /// The clock steps of the energy samples.
    sampled: Vec<u64>,
    /// `Ok(steps)` or the error in words, and the model's clock after the run.
    outcome: String,
    clock: u64,
}

/// Runs 5 steps, then 130 more with the guard every 40 steps, an observer every 30 steps of
/// the clock and energies every 25 steps of the run; cancels once progress reaches
/// `cancel_from` (if given).
fn trace(mut sim: Simulation, cancel_from: Option<u64>) -> Trace {
    sim.model.settings.guard_every = 40;
    run(&mut sim, 5).unwrap();
    let observed = Rc::new(RefCell::new(Vec::new()));
    let seen = observed.clone();
    sim.observers = vec![Observer {
        every: 30,
        call: Box::new(move |m| {
            seen.borrow_mut().push(m.clock.step);
            Ok(())
        }),
    }];
    let ctl = RunControl::default();
    let (mut progress, mut sampled) = (Vec::new(), Vec::new());
    let result = sim.run_sampled(
        130,
        25,
        &ctl,
        &mut |done| {
            progress.push(done);
            if cancel_from.is_some_and(|c| done >= c) {
                ctl.cancel.store(true, Ordering::Relaxed);
            }
        },
        &mut |s| sampled.push(s.step),
    );
    let outcome = match result {
        Ok(r) => format!("ok: {} steps", r.steps),
        Err(e) => e.to_string(),
    };
    let observed = observed.borrow().clone();
    Trace { observed, progress, sampled, outcome, clock: sim.model.clock.step }
}

#[test]
fn the_cpu_loop_observes_samples_guards_and_cancels_on_its_cadences() {
    let t = trace(Simulation::new(damped_glass_pair()), None);
    assert_eq!(t.observed, [30, 60, 90, 120], "observer steps of the clock");
    assert_eq!(t.sampled, [5, 30, 55, 80, 105, 130], "every 25th step of the run, from its first");
    // Chunks end on the run's guard steps (40, 80, 120), the observer's (clock 30, 60, 90,
    // 120 = run 25, 55, 85, 115) and the end.
    assert_eq!(t.progress, [25, 40, 55, 80, 85, 115, 120, 130]);
    assert_eq!((t.outcome.as_str(), t.clock), ("ok: 130 steps", 135));

    let t = trace(Simulation::new(damped_glass_pair()), Some(50));
    assert_eq!(t.progress, [25, 40, 55]);
    assert_eq!(t.outcome, "run cancelled after 55 step(s)");
    assert_eq!(t.clock, 5 + 55, "a cancelled run keeps the steps it made");
    assert_eq!(t.observed, [30, 60]);
}

#[test]
fn the_gpu_runs_the_same_loop_as_the_cpu() {
    let Some(ctx) = gpu("run_loop") else { return };
    for cancel in [None, Some(50)] {
        let cpu = trace(Simulation::new(damped_glass_pair()), cancel);
        let gpu = trace(Simulation::with_gpu(damped_glass_pair(), ctx.clone()), cancel);
        assert_eq!(gpu, cpu, "cancel from {cancel:?}");
    }
}

// A cancelled balance resumes where it stopped: the steps of both runs add up to the balance.
#[test]
fn a_cancelled_run_reports_the_steps_of_the_whole_balance() {
    use matdem_engine::Balance;
    let mut sim = Simulation::new(damped_glass_pair());
    sim.model.settings.guard_every = 40;
    let ctl = RunControl::default();
    let err = sim
        .balance(Balance::Steps(200), &ctl, &mut |done| {
            if done >= 100 {
                ctl.cancel.store(true, Ordering::Relaxed);
            }
        })
        .unwrap_err();
    assert!(matches!(err, Error::Cancelled { completed_steps: 120 }), "{err}");
    ctl.cancel.store(false, Ordering::Relaxed);
    let r = sim.balance_from(Balance::Steps(200), 120, &ctl, &mut |_| {}).unwrap();
    assert_eq!((r.steps, sim.model.clock.step), (200, 200));
}
