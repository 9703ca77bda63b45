//! The optional effects, one folder each: a stage of the step with its own lanes, allocated
//! only when a scene switches it on. A folder holds everything of its effect — the physics
//! (`physics.rs`), the scene's settings (`settings.rs`), the per-particle lanes (`lanes.rs`),
//! the CPU pass (`cpu.rs`), the GPU kernel (`gpu.rs`, beside `shaders/<name>.wgsl`) and, in
//! `mod.rs`, what a plan takes from the scene and the model-level calls that write its lanes.
//! The core step (walls, neighbour rows, contacts, integration, guard) stays in the backends.
pub mod applied_loads;
pub mod buoyancy;
pub mod clumps;
pub mod conduction;
pub mod confining_pressure;
pub mod heat_ledger;
pub mod moisture;
pub mod parallel_bond;
pub mod periodic;
pub mod pore_flow;
pub mod rolling_resistance;
