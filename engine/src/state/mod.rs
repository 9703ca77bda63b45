//! The model's state: particles (struct of arrays), contact rows with per-pair state, groups.

pub mod contacts;
pub mod groups;
pub mod moisture;
pub mod parallel_bonds;
pub mod particles;
pub mod thermal;
