//! The standard library of procedures, written in Rhai and embedded in the binary:
//! `import "std/oedometer" as oed;`. Their functions are also callable directly (and as
//! methods, e.g. `b.gravity_sediment()`), as MatDEM's built-in procedures are.

use rhai::module_resolvers::StaticModuleResolver;
use rhai::{Engine, Module, Scope};

/// (import path, source) of every stdlib script.
pub const SCRIPTS: &[(&str, &str)] = &[
    ("std/deposition", include_str!("../stdlib_scripts/deposition.rhai")),
    ("std/compaction", include_str!("../stdlib_scripts/compaction.rhai")),
    ("std/loading", include_str!("../stdlib_scripts/loading.rhai")),
    ("std/oedometer", include_str!("../stdlib_scripts/oedometer.rhai")),
    ("std/material_tests", include_str!("../stdlib_scripts/material_tests.rhai")),
    ("std/direct_shear", include_str!("../stdlib_scripts/direct_shear.rhai")),
    ("std/triaxial", include_str!("../stdlib_scripts/triaxial.rhai")),
];

/// Compiles the stdlib into modules and registers them as global functions; returns the
/// resolver that serves them to `import`.
pub fn install(engine: &mut Engine) -> StaticModuleResolver {
    let mut resolver = StaticModuleResolver::new();
    for (path, source) in SCRIPTS {
        let mut ast =
            engine.compile(*source).unwrap_or_else(|e| panic!("stdlib script {path} does not compile (a bug): {e}"));
        ast.set_source(*path);
        let module = Module::eval_ast_as_new(Scope::new(), &ast, engine)
            .unwrap_or_else(|e| panic!("stdlib script {path} failed to load (a bug): {e}"));
        resolver.insert(*path, module.clone());
        engine.register_global_module(module.into());
    }
    resolver
}

/// The source of a stdlib script, for error reports.
pub fn source(path: &str) -> Option<&'static str> {
    SCRIPTS.iter().find(|(p, _)| *p == path).map(|(_, s)| *s)
}
