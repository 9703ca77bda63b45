//! matdem-rs host: Rhai bindings, CLI, plots and outputs around `matdem-engine`.
