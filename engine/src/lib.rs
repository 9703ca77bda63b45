//! # matdem-engine
//!
//! The simulation engine of matdem-rs: a discrete element method in the manner of MatDEM.
//! It knows nothing of scripts, plots or terminals; a Rust program can use it directly.
//!
//! A tour:
//! - [`model::Model`] holds the state: [`state::particles::Particles`] (struct of arrays),
//!   neighbour rows with per-pair state ([`state::contacts::Contacts`]), materials, groups,
//!   walls, settings and the clock.
//! - [`physics`] holds the pure laws: MatDEM's linear elastic-brittle bonded contact, Hertz,
//!   Mindlin, dashpots from restitution, time-step estimates.
//! - [`materials`] converts macro properties (E, ν, Tu, Cu, μi) to micro parameters and back.
//! - [`plan::StepPlan`] decides once which effects a scene needs.
//! - [`neighbours`] builds the neighbour rows both backends step on (cell list, skin, the
//!   drift rule that says when to rebuild).
//! - [`backend`] steps the model: each [`backend::Backend`] (the CPU reference, f64; the GPU,
//!   f32) runs one step as named stages, a chunk of steps at a time, ending with the guard.
//! - [`simulation::Simulation`] runs many steps on either, with one run loop (chunks, the
//!   stability [`guard`]'s cadence, sampling, observers, cancellation) and MatDEM's `balance`.
//! - [`effects`] holds the optional effects, one folder each, every one a stage of the step
//!   that a scene pays for only when it switches it on: heat conduction with thermal expansion,
//!   the water table's buoyancy, the water content with evaporation, drying shrinkage and bond
//!   strength (conduction and moisture diffuse through the shared core [`diffusion`]), parallel
//!   bonds, rolling resistance, applied loads, the energy ledger, and pore density flow (the
//!   Delaunay pore network of the packing, fluid mass and pressure per pore, flow through the
//!   throats, pressure on the grains). [`plan::REGISTRY`] has a row per stage.
//! - [`planar`] makes a model 2D (one layer in the x–z plane, MatDEM's `sampleL = 0`): what it
//!   holds still, porosity by area, the hexagonal lattice's macro ↔ micro conversion.
//! - [`analysis`] reads a settled model: the contact list by the contact laws, fabric,
//!   Love–Weber stress, porosity and strain in a region.
//! - [`status`] measures energies, heat, coordination number and porosity;
//!   [`body_potential`] the water table's buoyant potential and the work of changing gravity
//!   or the table between runs.
//! - [`checkpoint`] saves a model to versioned, checksummed bytes and loads it back, so a
//!   later run continues it bit for bit.
//! - [`zoned`] packs concentric zones of growing grain size with mixing layers (paper 001);
//!   [`scaling`] makes scaled copies of a packing and scales materials by its law.
//! - [`bench`] builds the standard throughput scene and times it.
//!
//! Units are SI; particle ids are 0-based.

pub mod analysis;
pub mod backend;
pub mod bench;
pub mod body_potential;
pub mod bonding;
pub mod builder;
pub mod checkpoint;
pub mod diffusion;
pub mod effects;
pub mod element_values;
pub mod error;
pub mod geometry;
pub mod guard;
pub mod kill;
#[macro_use]
pub mod law_dispatch;
pub mod materials;
pub mod memory_budget;
pub mod model;
pub mod neighbours;
pub mod physics;
pub mod plan;
pub mod planar;
pub mod provenance;
pub mod scaling;
pub mod settings;
pub mod simulation;
pub mod space_filling;
pub mod state;
pub mod status;
pub mod training;
pub mod walls;
pub mod zoned;

pub use error::{Error, GpuError, Result};
pub use materials::{MacroProperties, Material};
pub use model::{Model, NormalKind, Settings, TangentialKind};
pub use physics::Vec3;
pub use plan::StepPlan;
pub use simulation::{Balance, Simulation};
pub use walls::{Wall, WallMotion, WallShape};
