//! Geometry before and around a model (MatDEM's `mfs` objects and `Tool_Cut`).
//!
//! - [`elements::ElementSet`]: centres and radii as whole arrays, not yet in a model, that
//!   move, rotate, combine and filter before they join one (`Model::add_particle`).
//! - [`lattice`]: regular packings (FCC, HCP, simple cubic) and the shapes MatDEM's `mfs`
//!   makes from them: box, column, ring, disc, sphere.
//! - [`surface::Surface`]: a height field through scattered points (terrain, layer
//!   boundaries, joints), triangulated in plan.
//! - [`polygon::Polygon`]: an outline in plan, for prism regions.
//! - [`sphere_box`]: the exact volume a sphere shares with a box or a vertical cylinder,
//!   for porosity by volume fraction.

pub mod elements;
pub mod lattice;
pub mod polygon;
pub mod region;
pub mod sphere_box;
pub mod surface;

pub use elements::ElementSet;
pub use lattice::LatticeKind;
pub use polygon::Polygon;
pub use surface::Surface;
