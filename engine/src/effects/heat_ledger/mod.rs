//! The energy ledger: the heat each particle releases, by cause (damping, contact dashpots,
//! friction, breakage), and the work walls do. Every cause is a by-product of a core law, so
//! the core passes book it where they compute it: the stage has no pass of its own, only lanes
//! (`Particles::heat`), allocated only for the causes a plan has (`d.heat_ledger = false`: none).
//!
//! The effect's folder: the lanes as the CPU passes see them (`cpu.rs`) and the GPU's ledger
//! slots and their fold into the model's f64 ledger (`gpu.rs`, with `shaders/heat_ledger.wgsl`).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
