//! The integration tests, one module per file, in one binary: a binary per file linked
//! wgpu, naga and rhai dozens of times over, which filled CI's disk (ld died with SIGBUS)
//! and spent minutes linking. A new test file needs its `mod` line here.

// The harness captures what tests print; the print macros' panic on a closed stream, which
// clippy.toml keeps out of the product, cannot reach a user from here.
#![allow(clippy::disallowed_macros)]

mod common;
// The module graph reader of module_deps.rs (and of the host's module_layers.rs).
mod module_graph;

mod applied_loads;
mod buoyancy;
mod buoyancy_energy;
mod checkpoint;
mod clumps;
mod conduction;
mod cone;
mod confining_pressure;
mod contact_analysis;
mod contact_laws;
mod energy_and_stability;
mod field_parity;
mod fixed_rotation;
mod forged_checkpoint;
mod gpu_energy;
mod gpu_parity;
mod gpu_resident;
mod guard_stiffness;
mod heat_dissipation;
mod lattice;
mod module_deps;
mod moisture;
mod parallel_bond;
mod periodic;
mod planar;
mod pore_coupling;
mod pore_flow;
mod pore_flow_balance;
mod pore_flow_parity;
mod pore_heat;
mod pore_heat_parity;
mod pore_network;
mod rolling_resistance;
mod run_loop;
mod runaway_inputs;
mod scaling_law;
mod servo;
mod speed_test;
mod stage_lanes;
mod strip;
mod tangential_damping;
mod training;
mod triaxial_elastic;
mod zoned;
