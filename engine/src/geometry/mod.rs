//! Geometry before and around a model (MatDEM's `mfs` objects and `Tool_Cut`).
//!
//! - [`elements::ElementSet`]: centres and radii as whole arrays, not yet in a model, that
//!   move, rotate, combine and filter before they join one (`Model::add_particle`).
//! - [`lattice`]: regular packings (FCC, HCP, simple cubic) and the shapes MatDEM's `mfs`
//!   makes from them: box, column, ring, disc, sphere.

pub mod elements;
pub mod lattice;

pub use elements::ElementSet;
pub use lattice::LatticeKind;
