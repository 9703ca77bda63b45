//! The `matdem-rs` command: parses the arguments and hands off to a command.

mod cli;
mod commands;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    commands::quiet_mesa();
    let cli = cli::Cli::parse();
    match commands::dispatch(cli.command) {
        Ok(code) => code,
        Err(failure) => {
            // Errors quote scripts, manifests, CSV cells and sweep folders: show their control
            // characters rather than let the terminal obey them.
            eprint!("{}", matdem_rs::terminal_text::lines(&failure.text));
            ExitCode::from(failure.code)
        }
    }
}
