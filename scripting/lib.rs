//! matdem-rs host: Rhai bindings, CLI, plots and outputs around `matdem-engine`.
//!
//! [`new_engine`] builds a Rhai engine with the whole script API and the embedded
//! standard library; [`script_run::run_script`] runs a script file into an output folder;
//! [`report`] renders errors with file, line, column and a caret.
//!
//! The modules stand in layers, each naming only modules of its own layer or below, in no
//! circle (tests/module_layers.rs checks, and holds the table): core (atomic writes, the
//! sandbox, the resume journal, metrics, the run record, error rendering, …) ← outputs
//! (plots, particle pictures, movies, snapshots, the report page) ← workflows (calibration,
//! packages, sweeps, studies) ← the script API ([`api`], [`new_engine`]) ← front ends
//! ([`run`], [`repl`], [`bench`] and the binary's command line).

pub mod api;
pub mod atomic_write;
pub mod bench;
pub mod calibration;
pub mod console;
pub mod memory;
pub mod metrics;
pub mod movie;
pub mod out_lock;
pub mod package;
pub mod picture_fields;
pub mod plot;
pub mod repl;
pub mod report;
pub mod report_page;
pub mod resume;
pub mod run_backend;
pub mod run_record;
pub mod sandbox;
pub mod script_run;
pub mod snapshot;
pub mod stdlib;
pub mod stop;
pub mod study;
pub mod sweep;
pub mod terminal_text;

use api::Host;
use rhai::Engine;
use sandbox::SandboxModules;
use std::rc::Rc;

/// A Rhai engine with the script API, the standard library (`import "std/…"`) and the
/// host's sandbox: its limits, and `import "helpers"` served from the script's own folder
/// or package (helpers.rhai there), nowhere else.
pub fn new_engine(host: Rc<Host>) -> Engine {
    let mut engine = Engine::new();
    api::register(&mut engine, host.clone());
    // The stdlib is ours and compiles under the engine's own limits; the script's limits,
    // however small, apply to what runs after.
    let stdlib = stdlib::install(&mut engine);
    host.limits.apply(&mut engine);
    engine.set_module_resolver(SandboxModules { root: host.read_root.clone(), stdlib });
    // A resumed run replays the script's start silently: it printed that the first time.
    // What a script prints reaches a terminal: its control characters are shown, not obeyed.
    // A reader that went away (`matdem-rs run s.rhai | head -1`) must not stop the run, whose
    // outputs are still being written: `outln!` drops the line (console.rs).
    let h = host.clone();
    engine.on_print(move |text| {
        if !h.replaying() {
            outln!("{}", terminal_text::lines(text));
        }
    });
    // Rhai's own `debug` output, the same way (source and position as Rhai prints them).
    engine.on_debug(move |text, source, pos| {
        if host.replaying() {
            return;
        }
        let text = terminal_text::lines(text);
        match (source.map(terminal_text::one_line), pos.is_none()) {
            (Some(source), true) => outln!("{source} | {text}"),
            (Some(source), false) => outln!("{source} @ {pos:?} | {text}"),
            (None, true) => outln!("{text}"),
            (None, false) => outln!("{pos:?} | {text}"),
        }
    });
    engine
}
