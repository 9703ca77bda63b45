//! `study`: what accuracy costs in time, one setting per run.

use super::{backend_name, own_exe, stop_on_signals, Failure, Outcome};
use crate::cli::Backend;
use matdem_engine::backend::RunControl;
use matdem_rs::study::{run_study, summary, StudyConfig, Vary};
use matdem_rs::{eoutln, out};
use std::path::PathBuf;
use std::process::ExitCode;

pub struct StudyArgs {
    pub script: PathBuf,
    pub vary: Vec<Vary>,
    pub metric: String,
    pub fixed: Vec<String>,
    pub reference: Option<String>,
    pub out: Option<PathBuf>,
    pub backend: Backend,
    pub jobs: usize,
    pub max_points: usize,
}

pub fn study(args: StudyArgs) -> Outcome {
    let reference = args.reference.map(|r| parse_reference(&r)).transpose().map_err(Failure::error)?;
    let exe = own_exe().map_err(Failure::error)?;
    let control = RunControl::default();
    stop_on_signals(&control, "the study without letting its running setting save");
    let cfg = StudyConfig {
        control,
        exe,
        script: args.script,
        out_dir: args.out.unwrap_or_else(|| PathBuf::from("out/study")),
        vary: args.vary,
        fixed: args.fixed,
        metric: args.metric,
        reference,
        backend: backend_name(args.backend),
        jobs: args.jobs,
        max_points: args.max_points,
    };
    // Each setting's run locks its own runNN folder; the sweep holds the folder around them.
    match run_study(&cfg, |line| eoutln!("{line}")) {
        Ok((s, written)) => {
            out!("{}", summary(&s, &cfg.metric));
            eoutln!("wrote {} file(s) under {}", written.len(), cfg.out_dir.display());
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => Err(Failure::said(if cfg.control.is_cancelled() { 130 } else { 1 }, format!("error: {e}"))),
    }
}

fn parse_reference(s: &str) -> Result<Vec<(String, String)>, String> {
    s.split(',')
        .map(|kv| match kv.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => Ok((k.trim().to_string(), v.trim().to_string())),
            _ => Err(format!("--reference expects NAME=VALUE,..., got `{s}`")),
        })
        .collect()
}
