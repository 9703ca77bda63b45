//! What training needs of the lattice formulas, for 3D samples (paper 003's FCC lattice) and
//! 2D ones (the bonded hexagonal layer, `planar::conversion`): the starting material, the
//! formulas' reading of a material, and the relations the corrections move along.

use crate::error::Result;
use crate::materials::{MacroProperties, Material};
use crate::planar::conversion::{micro_to_macro_2d, min_internal_friction_2d, MAX_POISSON_2D};
use serde::{Deserialize, Serialize};
use std::f64::consts::SQRT_2;

const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// Which lattice's formulas a training starts from and corrects along.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Dimension {
    /// A box of spheres; paper 003's formulas.
    #[default]
    Three,
    /// One layer in the x–z plane (a 2D model); the hexagonal layer's formulas.
    Two,
}

impl Dimension {
    /// The material the formulas give for `targets` at element diameter `d`.
    pub fn material(self, name: &str, density: f64, targets: &MacroProperties, d: f64) -> Result<Material> {
        match self {
            Dimension::Three => Material::from_macro(name, density, targets, d),
            Dimension::Two => Material::from_macro_2d(name, density, targets, d),
        }
    }

    /// What the formulas say `m` gives at diameter `d`.
    pub fn lattice_macro(self, m: &Material, d: f64) -> MacroProperties {
        match self {
            Dimension::Three => m.lattice_macro(d),
            Dimension::Two => micro_to_macro_2d(&m.micro(), d),
        }
    }

    /// The largest ν the formulas reach (Ks = 0).
    pub fn max_poisson(self) -> f64 {
        match self {
            Dimension::Three => 0.2,
            Dimension::Two => MAX_POISSON_2D,
        }
    }

    /// The smallest μi the formulas reach (μp = 0).
    pub fn min_internal_friction(self) -> f64 {
        match self {
            Dimension::Three => 1.0 / (2.0 * SQRT_2),
            Dimension::Two => min_internal_friction_2d(),
        }
    }

    /// Ks/Kn for ν: 3D ν = (1 − s)/(5 + s), 2D ν = (1 − s)/(3 + s).
    pub fn shear_ratio(self, nu: f64) -> f64 {
        match self {
            Dimension::Three => (1.0 - 5.0 * nu) / (1.0 + nu),
            Dimension::Two => (1.0 - 3.0 * nu) / (1.0 + nu),
        }
    }

    /// E over Kn at a shear ratio s, up to a constant: 3D (1 + s)/(5 + s), 2D (1 + s)/(3 + s).
    pub fn young_factor(self, s: f64) -> f64 {
        match self {
            Dimension::Three => (1.0 + s) / (5.0 + s),
            Dimension::Two => (1.0 + s) / (3.0 + s),
        }
    }

    /// μp for μi.
    pub fn mu_p(self, mu_i: f64) -> f64 {
        let i = ((1.0 + mu_i * mu_i).sqrt() + mu_i).powi(2);
        let mu_p = match self {
            Dimension::Three => (-2.0 * SQRT_2 + SQRT_2 * i) / (2.0 + 2.0 * i),
            Dimension::Two => (2.0 * i - 3.0) / (SQRT_3 * (1.0 + 2.0 * i)),
        };
        mu_p.max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The relations the corrections move along agree with the formulas themselves.
    #[test]
    fn the_correction_relations_agree_with_each_lattices_formulas() {
        for dim in [Dimension::Three, Dimension::Two] {
            let targets =
                MacroProperties { young: 2e10, poisson: 0.15, tensile: 5e6, compressive: 5e7, internal_friction: 0.7 };
            let m = dim.material("t", 2650.0, &targets, 1e-3).unwrap();
            assert!((m.ks / m.kn - dim.shear_ratio(0.15)).abs() < 1e-12, "{dim:?}");
            assert!((m.mu_p - dim.mu_p(0.7)).abs() < 1e-12, "{dim:?}");
            let back = dim.lattice_macro(&m, 1e-3);
            assert!((back.young / 2e10 - 1.0).abs() < 1e-12 && (back.poisson - 0.15).abs() < 1e-12, "{dim:?}");
            // E ∝ Kn·young_factor(s): doubling Kn at the same s doubles E.
            let mut twice = m.clone();
            (twice.kn, twice.ks) = (2.0 * m.kn, 2.0 * m.ks);
            assert!((dim.lattice_macro(&twice, 1e-3).young / 4e10 - 1.0).abs() < 1e-12);
            assert!(dim.mu_p(dim.min_internal_friction()).abs() < 1e-12, "{dim:?}");
            assert!(dim.shear_ratio(dim.max_poisson()).abs() < 1e-12, "{dim:?}");
        }
    }
}
