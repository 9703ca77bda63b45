//! Parallel bonds (Potyondy & Cundall 2004; docs/parallel-bond.md): a cemented disc in
//! parallel with the linear contact, carrying force and moment until its tensile or shear
//! strength breaks it. An optional force stage: its lanes (the bonds' rows and states) exist only
//! in scenes that made such bonds (`Model::bond_parallel`, in bonding.rs).
//!
//! The effect's folder: the bond's law (`physics.rs`, whose parameters are the scene's setting),
//! the bonds' rows and states (`lanes.rs`), the CPU pass (`cpu.rs`) and the GPU kernel (`gpu.rs`,
//! with `shaders/parallel_bond.wgsl`).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod lanes;
pub mod physics;

use physics::ParallelBondParams;

/// The stage in the plan's words, with `bonds` intact bonds.
pub fn words(p: &ParallelBondParams, bonds: usize) -> String {
    format!(
        "parallel bonds({bonds} bonds, λ̄ {}, Ē* {:e} Pa, k̄* {}, σ̄c {:e} Pa, c̄ {:e} Pa, φ̄ {}°)",
        p.lambda,
        p.e_star,
        p.k_ratio,
        p.sigma_c,
        p.cohesion,
        p.phi.to_degrees()
    )
}
