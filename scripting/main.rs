//! The `matdem-rs` command: parses the arguments and hands off to a command.

mod cli;
mod commands;

use clap::Parser;
use matdem_rs::{eout, eoutln};
use std::process::ExitCode;

fn main() -> ExitCode {
    // A panic is a bug, never a message meant for the user: say so, and where the work is,
    // before Rust's own report of it.
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        eoutln!(
            "internal error: this is a bug in matdem-rs — please report it with the script and the command \
             line; what the run wrote before it is kept in its output folder"
        );
        report(info);
    }));
    commands::quiet_mesa();
    let cli = cli::Cli::parse();
    match commands::dispatch(cli.command) {
        Ok(code) => code,
        Err(failure) => {
            // Errors quote scripts, manifests, CSV cells and sweep folders: show their control
            // characters rather than let the terminal obey them.
            eout!("{}", matdem_rs::terminal_text::lines(&failure.text));
            ExitCode::from(failure.code)
        }
    }
}
