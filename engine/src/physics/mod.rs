//! Pure physics: contact laws, dashpots from restitution and time-step estimates. These
//! functions are the specification; backends call them (CPU) or mirror them (WGSL).

pub mod contact_law;
pub mod law_kinds;
pub mod restitution;
pub mod timestep;

/// Vector type of the CPU reference backend (f64).
pub type Vec3 = nalgebra::Vector3<f64>;
