//! `sweep`: parameter sweeps as folders, run here or on Slurm.

use super::{backend_name, own_exe, stop_on_signals};
use crate::cli::SweepCommand;
use matdem_engine::backend::RunControl;
use matdem_rs::out_lock::OutLock;
use matdem_rs::package::Package;
use matdem_rs::sweep::point::PointRun;
use matdem_rs::terminal_text::one_line;
use matdem_rs::{eout, eoutln, out, outln};

pub fn sweep(action: SweepCommand) -> Result<(), String> {
    use matdem_rs::sweep::{collect, plan, slurm};
    match action {
        SweepCommand::Plan { source, out, vary, runs, set, backend, replace, max_points } => {
            let fixed = set
                .iter()
                .map(|f| match f.split_once('=') {
                    Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
                    _ => Err(format!("--set expects NAME=VALUE, got `{f}`")),
                })
                .collect::<Result<Vec<_>, String>>()?;
            let mut request = plan::PlanRequest {
                source,
                dir: out.clone(),
                backend: backend_name(backend),
                fixed,
                design: plan::Design::Runs { from: String::new() },
                runs: Vec::new(),
                study: None,
                replace,
                max_points,
            };
            let planned = match runs {
                Some(file) => {
                    request.runs = plan::read_runs_csv(&file, max_points)?;
                    request.design = plan::Design::Runs { from: plan::absolute(&file).display().to_string() };
                    plan::plan(request)?
                }
                None if vary.is_empty() => return Err("give --vary NAME=v1,v2,... or --runs FILE.csv".into()),
                None => {
                    let mut names: Vec<&str> = Vec::new();
                    for v in &vary {
                        if names.contains(&v.name.as_str()) {
                            return Err(format!("--vary {} is given twice; list all its values in one --vary", v.name));
                        }
                        names.push(&v.name);
                    }
                    plan::plan_grid(request, vary.into_iter().map(|v| (v.name, v.values)).collect())?
                }
            };
            warn_refused_values(&planned);
            eoutln!(
                "planned {} point(s) in {}; run them with `matdem-rs sweep run {} --local -j N` or `matdem-rs sweep \
                 slurm {} --submit`",
                planned.points.len(),
                out.display(),
                out.display(),
                out.display()
            );
            Ok(())
        }
        SweepCommand::Run { dir, local: _, jobs, retry_failed } => {
            let planned = plan::load(&dir)?;
            let control = RunControl::default();
            stop_on_signals(&control, "the sweep without letting its points save");
            let exe = own_exe()?;
            let opts = matdem_rs::sweep::LocalOptions { jobs, retry_failed, exe, control: control.clone() };
            let result = matdem_rs::sweep::run_local(&dir, &planned, &opts, |line| eoutln!("{line}"));
            if let Err(e) = result {
                if control.is_cancelled() {
                    eoutln!("error: {e}");
                    std::process::exit(130);
                }
                return Err(e);
            }
            let results = collect::results(&dir, &planned)?;
            eout!("{}", collect::status_text(&dir, &planned, &results));
            Ok(())
        }
        SweepCommand::Slurm {
            dir,
            partition,
            time,
            cpus_per_task,
            mem,
            account,
            max_parallel,
            retry_failed,
            submit,
        } => {
            let planned = plan::load(&dir)?;
            let exe = own_exe()?;
            let _sweep = OutLock::acquire_shared(&dir, "sweep slurm")?;
            let opts = slurm::SlurmOptions { partition, time, cpus_per_task, mem, account, max_parallel, retry_failed };
            let Some((script, tasks)) = slurm::write_script(&dir, &planned, &exe, &opts)? else {
                eoutln!("every point of {} is finished; nothing to submit", dir.display());
                return Ok(());
            };
            eoutln!("wrote {} ({tasks} array task(s))", script.display());
            if submit {
                let id = slurm::submit(&script)?;
                outln!("{id}");
                eoutln!(
                    "submitted job {id}; follow it with `matdem-rs sweep status {}`, merge with `matdem-rs sweep \
                     collect {}`",
                    dir.display(),
                    dir.display()
                );
            } else {
                eoutln!("submit it with `sbatch {}`", script.display());
            }
            Ok(())
        }
        SweepCommand::Status { dir } => {
            let planned = plan::load(&dir)?;
            let results = collect::results(&dir, &planned)?;
            out!("{}", collect::status_text(&dir, &planned, &results));
            Ok(())
        }
        SweepCommand::Collect { dir } => {
            let planned = plan::load(&dir)?;
            // Its tables are written beside the points: not while a plan or a run holds the folder.
            let _sweep = OutLock::acquire_shared(&dir, "sweep collect")?;
            let results = collect::results(&dir, &planned)?;
            let written = matdem_rs::study::write_collect(&dir, &planned, &results)?;
            out!("{}", collect::status_text(&dir, &planned, &results));
            eoutln!("wrote {} file(s) under {}", written.len(), dir.display());
            Ok(())
        }
        SweepCommand::Point { dir, index } => {
            let planned = plan::load(&dir)?;
            if index >= planned.points.len() {
                return Err(format!("the sweep has {} point(s); index {index} is not one", planned.points.len()));
            }
            matdem_rs::sweep::point::check_source(&planned)?;
            let name = &planned.points[index].name;
            if !matdem_rs::sweep::point::is_pending(&dir, name, true)? {
                eoutln!("{name} finished already; skipped");
                return Ok(());
            }
            let control = RunControl::default();
            stop_on_signals(&control, "the point without letting it save");
            let exe = own_exe()?;
            // Shared with the sweep's other points, exclusive of a plan that would replace it.
            let _sweep = OutLock::acquire_shared(&dir, &format!("sweep point {index}"))?;
            let run = matdem_rs::sweep::point::run_point(&dir, &planned, index, &exe, None, &control)?;
            let PointRun::Ran(outcome) = run else {
                eoutln!("{name} is running in another process; left alone (see `matdem-rs sweep status`)");
                return Ok(());
            };
            eoutln!(
                "{name}: {:?} in {:.1} s{}",
                outcome.status,
                outcome.wall_s,
                outcome.error.map(|e| format!(": {}", one_line(&e))).unwrap_or_default()
            );
            Ok(())
        }
    }
}

/// Points whose values a package refuses still run (and fail with the reason, so the sweep's
/// table shows it); say so now rather than after the queue.
fn warn_refused_values(planned: &matdem_rs::sweep::SweepPlan) {
    let Ok(Some(package)) = Package::detect(&planned.source) else { return };
    for p in &planned.points {
        let set: Vec<String> = p
            .parameters
            .iter()
            .chain(&planned.fixed)
            .filter(|(n, _)| n != "backend")
            .map(|(n, v)| format!("{n}={v}"))
            .collect();
        if let Err(e) = package.params(&set) {
            eoutln!("warning: {} will fail: {}", p.name, one_line(&e));
        }
    }
}
