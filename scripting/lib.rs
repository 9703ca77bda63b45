//! matdem-rs host: Rhai bindings, CLI, plots and outputs around `matdem-engine`.
//!
//! [`new_engine`] builds a Rhai engine with the whole script API and the embedded
//! standard library; [`run::run_script`] runs a script file into an output folder;
//! [`report`] renders errors with file, line, column and a caret.

pub mod api;
pub mod atomic;
pub mod bench;
pub mod plot;
pub mod report;
pub mod resume;
pub mod run;
pub mod run_record;
pub mod snapshot;
pub mod stdlib;
pub mod study;

use api::Host;
use rhai::module_resolvers::{FileModuleResolver, ModuleResolversCollection};
use rhai::Engine;
use std::path::Path;
use std::rc::Rc;

/// Limits that keep a shared script from exhausting the machine.
fn set_limits(engine: &mut Engine) {
    engine.set_max_call_levels(64);
    engine.set_max_expr_depths(128, 64);
    engine.set_max_string_size(16 << 20);
    engine.set_max_array_size(10_000_000);
    engine.set_max_map_size(100_000);
}

/// A Rhai engine with the script API and the standard library (`import "std/…"`);
/// `script_dir` serves a script's own modules (`import "helpers"` → helpers.rhai there).
pub fn new_engine(host: Rc<Host>, script_dir: Option<&Path>) -> Engine {
    let mut engine = Engine::new();
    set_limits(&mut engine);
    api::register(&mut engine, host.clone());
    // A resumed run replays the script's start silently: it printed that the first time.
    engine.on_print(move |text| {
        if !host.replaying() {
            println!("{text}");
        }
    });
    let mut resolvers = ModuleResolversCollection::new();
    resolvers.push(stdlib::install(&mut engine));
    if let Some(dir) = script_dir {
        resolvers.push(FileModuleResolver::new_with_path(dir));
    }
    engine.set_module_resolver(resolvers);
    engine
}
