//! The integration tests, one module per file, in one binary: a binary per file linked
//! wgpu, naga and rhai dozens of times over, which filled CI's disk (ld died with SIGBUS)
//! and spent minutes linking. A new test file needs its `mod` line here.

// The harness captures what tests print; the print macros' panic on a closed stream, which
// clippy.toml keeps out of the product, cannot reach a user from here.
#![allow(clippy::disallowed_macros)]

mod common;
// The module graph reader the engine's dependency test uses too.
#[path = "../engine/tests/module_graph.rs"]
mod module_graph;

mod analysis_script;
mod applied_loads_script;
mod auto_backend_cli;
mod bench_cli;
mod calibration_script;
mod checkpoint_cli;
mod cli;
mod clumps_script;
mod cpt_cli;
mod cutting;
mod direct_shear;
mod direct_shear_calibration_cli;
mod drying_crack_cli;
mod energy_pile_cli;
mod field_maths;
mod fields_script;
mod geometry_objects;
mod gpu_test_names;
mod guard;
mod hardening;
mod hardening_bounds;
mod hardening_escapes;
mod hardening_locks;
mod hardening_messages;
mod hot_cold_injection_cli;
mod hydraulic_fracture_cli;
mod land_subsidence_cli;
mod material_provenance;
mod model_surgery;
mod module_layers;
mod movie_cli;
mod oedometer_seeds;
mod packages;
mod parallel_bond_cli;
mod periodic_script;
mod periodic_shear_cli;
mod planar_script;
mod pore_flow_script;
mod porosity_and_statistics;
mod repl;
mod repl_terminal;
mod report_page;
mod resume_cli;
mod robustness;
mod rotate_export;
mod sandbox;
mod script_api;
mod script_errors;
mod script_reference;
mod slope_cli;
mod snapshot_cli;
mod stage_switches;
mod study_cli;
mod sweep_cli;
mod sweep_slurm;
mod training_cli;
mod triaxial_cli;
mod tunnel_cli;
mod zones_script;
