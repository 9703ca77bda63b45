//! `info` and `pack`: packaged simulators.

use super::{Failure, Outcome};
use matdem_rs::package::Package;
use matdem_rs::{eoutln, out};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

pub fn info(path: &Path) -> Outcome {
    let package = Package::open(path).map_err(Failure::error)?;
    out!("{}", package.describe());
    Ok(ExitCode::SUCCESS)
}

pub fn pack(dir: &Path, output: Option<PathBuf>) -> Outcome {
    let output = match output {
        Some(o) => o,
        None => {
            let p = Package::open(dir).map_err(Failure::error)?;
            PathBuf::from(format!("{}-{}.tar", p.manifest.name, p.manifest.version))
        }
    };
    let n = matdem_rs::package::pack(dir, &output).map_err(Failure::error)?;
    eoutln!("packed {n} file(s) into {}; run it with `matdem-rs run {}`", output.display(), output.display());
    Ok(ExitCode::SUCCESS)
}
