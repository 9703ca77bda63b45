//! Running and balancing the model, journaled so an interrupted run can resume.

use super::*;
use crate::{eoutln, outln};
// Model names come from the script and are printed: escaped for the terminal.
use crate::terminal_text::one_line;

/// Runs or balances the model (`call` names the script function), with progress and
/// cancellation; in plan mode prints the plan instead. Journaled like every observation: a
/// resumed run gives back what the call returned, and at the interrupted call restores the
/// models and runs the rest of its steps. Cancelled, it writes the resume folder and ends
/// the script.
fn run_steps(host: &Host, d: &ModelHandle, call: &str, how: Balance) -> RhaiResult<Dynamic> {
    // `--backend auto` decides at the first run (never while planning or replaying: those
    // runs are decided from the start).
    crate::api::auto_backend::settle(host, d).map_err(err)?;
    {
        let mut data = d.data();
        if !data.plan_noted {
            let plan = data.sim.plan_text();
            if host.plan_only {
                // The plan names the script's groups and materials: escaped like the name.
                outln!(
                    "model `{}` ({} particles):\n{}",
                    one_line(&data.name),
                    data.sim.model.len(),
                    crate::terminal_text::lines(&plan)
                );
            }
            host.plans.borrow_mut().push((data.name.clone(), plan));
            data.plan_noted = true;
        }
    }
    if host.plan_only {
        return Err(Stop::PlanDone.unwind());
    }
    let (how, done) = {
        let s = host.session.borrow();
        match &s.pending {
            Some(p) if s.cursor == p.interrupted.index => {
                drop(s);
                resume_point::restore(host, call, how)?
            }
            _ if s.replaying() => {
                drop(s);
                return host.observe(call, || unreachable_in_replay(call));
            }
            _ => {
                drop(s);
                // A standard balance becomes its step count now, so a resume runs the same count.
                let how = match how {
                    Balance::Standard { rounds } => {
                        Balance::Steps((d.data().sim.standard_balance_steps() as f64 * rounds).ceil() as u64)
                    }
                    other => other,
                };
                (how, 0)
            }
        }
    };
    let mut cancelled = None;
    let result = host.observe(call, || {
        let mut data = d.data();
        let total = match how {
            Balance::Steps(n) => n,
            Balance::Standard { rounds } => (data.sim.standard_balance_steps() as f64 * rounds).ceil() as u64,
            Balance::Tolerance { max_steps, .. } => max_steps,
        };
        let bar = (host.progress && total >= 2000).then(|| {
            let b = indicatif::ProgressBar::new(total);
            b.set_style(
                indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} steps, {per_sec}, {eta} left")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_message(format!("{}: balance", data.name));
            b.set_position(done);
            b
        });
        let mut progress = |k: u64| {
            if let Some(b) = &bar {
                b.set_position(k);
            }
        };
        let started = std::time::Instant::now();
        let rep = data.sim.balance_from(how, done, &host.control, &mut progress);
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        // The warn-mode guard's warning, after the bar is gone (a run that then failed or
        // was cancelled still gives it).
        if let Some(w) = data.sim.take_warning() {
            host.warn(&format!("stiff contact in {}", data.name), w.to_string());
        }
        // Without a terminal there is no bar: a log still hears of each long balance.
        let secs = started.elapsed().as_secs_f64();
        if let (false, Ok(r)) = (host.progress, &rep) {
            if secs >= LOG_BALANCE_AFTER_S {
                let rate = r.steps as f64 * data.sim.model.len() as f64 / secs;
                eoutln!(
                    "{}: {call} of {} steps in {secs:.1} s ({rate:.3e} particle-steps/s)",
                    one_line(&data.name),
                    r.steps
                );
            }
        }
        let rep = match rep {
            Err(matdem_engine::Error::Cancelled { completed_steps }) => {
                cancelled = Some(completed_steps);
                return Err(Stop::Interrupted.unwind());
            }
            other => other.map_err(|e| host.raise_engine(e))?,
        };
        let mut map = Map::new();
        map.insert("steps".into(), (rep.steps as INT).into());
        if let Some(r) = rep.unbalanced_ratio {
            map.insert("unbalanced_ratio".into(), r.into());
        }
        Ok(Dynamic::from_map(map))
    });
    if let Some(completed) = cancelled {
        if !host.resumable {
            return Err(raise(matdem_engine::Error::Cancelled { completed_steps: completed }));
        }
        // The journal must end before this call: take back the entry `observe` made for it.
        host.session.borrow_mut().entries.pop();
        let saved = SavedBalance::from_balance(how).expect("standard balances were turned into steps above");
        let dir = resume_point::write_resume(host, call, saved, completed).map_err(err)?;
        let name = one_line(&d.data().name).into_owned();
        eoutln!(
            "interrupted: `{name}` stopped after {completed} step(s) of its {call}; resume data in {}",
            dir.display()
        );
        return Err(Stop::Interrupted.unwind());
    }
    result
}

/// A balance that takes at least this long is logged when no progress bar is drawn.
const LOG_BALANCE_AFTER_S: f64 = 5.0;

/// A replayed run call never runs: `observe` answers it from the journal.
fn unreachable_in_replay(call: &str) -> RhaiResult<Dynamic> {
    Err(err(format!("internal error: `{call}` ran while replaying; please report this bug")))
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    let h = host.clone();
    engine.register_fn("run", move |d: &mut ModelHandle, steps: Dynamic| {
        let steps = step_count(&steps, "run", "steps")?;
        run_steps(&h, d, "run", Balance::Steps(steps))
    });
    let h = host.clone();
    engine.register_fn("balance", move |d: &mut ModelHandle| {
        run_steps(&h, d, "balance", Balance::Standard { rounds: 1.0 })
    });
    let h = host.clone();
    engine.register_fn("balance", move |d: &mut ModelHandle, how: Dynamic| {
        let mode = balance_mode(&how, 1.0)?;
        run_steps(&h, d, "balance", mode)
    });
    let h = host.clone();
    engine.register_fn("balance", move |d: &mut ModelHandle, how: &str, rounds: Dynamic| {
        let rounds = number(&rounds).ok_or_else(|| err("balance: rounds must be a number"))?;
        let mode = balance_mode(&Dynamic::from(how.to_string()), rounds)?;
        run_steps(&h, d, "balance", mode)
    });
    let h = host.clone();
    engine.register_fn("balance_until", move |d: &mut ModelHandle, ratio: FLOAT, max_steps: Dynamic| {
        positive("ratio", ratio)?;
        let max_steps = step_count(&max_steps, "balance_until", "max_steps")?;
        if max_steps == 0 {
            return Err(err("balance_until: max_steps must be > 0"));
        }
        run_steps(&h, d, "balance_until", Balance::Tolerance { ratio, max_steps })
    });
}

/// A count of steps: an integer ≥ 0, or a float that is one (MatDEM's scripts write 1e5, which
/// Rhai reads as a float), at most 2^53 so that it is exact.
fn step_count(v: &Dynamic, call: &str, what: &str) -> RhaiResult<u64> {
    const EXACT: f64 = 9_007_199_254_740_992.0;
    if let Ok(n) = v.as_int() {
        return u64::try_from(n).map_err(|_| err(format!("{call}: {what} must be ≥ 0, got {n}")));
    }
    match v.as_float() {
        Ok(x) if x.is_finite() && x >= 0.0 && x.fract() == 0.0 && x <= EXACT => Ok(x as u64),
        Ok(x) => Err(err(format!("{call}: {what} must be a whole number of steps ≥ 0, got {x}"))),
        Err(t) => Err(err(format!("{call}: {what} must be a number of steps, got {t}"))),
    }
}

fn balance_mode(how: &Dynamic, rounds: f64) -> RhaiResult<Balance> {
    if how.is_int() || how.is_float() {
        return Ok(Balance::Steps(step_count(how, "balance", "steps")?));
    }
    match how.clone().try_cast::<rhai::ImmutableString>().as_deref() {
        Some("standard") | Some("Standard") => {
            positive("rounds", rounds)?;
            Ok(Balance::Standard { rounds })
        }
        Some(other) => Err(raise(matdem_engine::Error::unknown("balance mode", other, &["standard"]))),
        None => Err(err(format!("balance: expected \"standard\" or a number of steps, got {}", how.type_name()))),
    }
}
