//! The host's two terminal streams. `println!` and `eprintln!` panic when their stream has
//! gone away — a pipe whose reader closed (`matdem-rs doc | head`, `matdem-rs run s.rhai |
//! head -3`), a terminal that was shut — and a panic would end a run with its outputs half
//! written. These macros write the same text and drop what cannot be written, so the work goes
//! on: what a run keeps is in its output folder, not on its terminal. clippy.toml refuses the
//! std print macros everywhere but in tests. Rust puts exported macros at the crate root
//! (`use crate::outln`, `use matdem_rs::eoutln`); the layer test counts them as this module.

use std::fmt::Arguments;
use std::io::Write;

/// Writes to stdout, dropping the text when stdout has gone away.
#[doc(hidden)]
pub fn to_stdout(text: Arguments) {
    let _ = std::io::stdout().lock().write_fmt(text);
}

/// Writes to stderr, dropping the text when stderr has gone away.
#[doc(hidden)]
pub fn to_stderr(text: Arguments) {
    let _ = std::io::stderr().lock().write_fmt(text);
}

/// `print!` that cannot panic: the text is dropped when stdout has gone away.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => { $crate::console::to_stdout(format_args!($($arg)*)) };
}

/// `println!` that cannot panic: the line is dropped when stdout has gone away.
#[macro_export]
macro_rules! outln {
    () => { $crate::console::to_stdout(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::console::to_stdout(format_args!("{}\n", format_args!($($arg)*))) };
}

/// `eprint!` that cannot panic: the text is dropped when stderr has gone away.
#[macro_export]
macro_rules! eout {
    ($($arg:tt)*) => { $crate::console::to_stderr(format_args!($($arg)*)) };
}

/// `eprintln!` that cannot panic: the line is dropped when stderr has gone away.
#[macro_export]
macro_rules! eoutln {
    () => { $crate::console::to_stderr(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::console::to_stderr(format_args!("{}\n", format_args!($($arg)*))) };
}
