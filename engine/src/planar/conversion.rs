//! Macro ↔ micro for a 2D model: a bonded hexagonal (triangular) lattice of spheres of diameter
//! d in one layer, read as a plate of thickness t = d in plane stress. The 2D counterpart of
//! paper 003's appendix A (`materials::macro_to_micro`), derived the same way (docs/physics.md,
//! "2D models"):
//!
//! - E and ν from the affine deformation of the lattice (every element a centre of symmetry):
//!   λ = √3/4·(Kn − Ks)/t, μ = √3/4·(Kn + Ks)/t, so E = 2√3·Kn(Kn+Ks)/(t(3Kn+Ks)) and
//!   ν = (Kn − Ks)/(3Kn + Ks); the 2D lattice is isotropic, so these hold in every direction.
//! - Tu from the bonds inclined at 30° to a uniaxial tension normal to the close-packed rows
//!   (the 3D formula's bonds across the close-packed layers): Kn·Xb = Tu·d²(2Kn+Ks)/(2√3(Kn+Ks)).
//! - Cu and μi from the same bonds failing in shear under σ1 normal to the rows and σ3 along
//!   them, each carrying its share of the load as the 3D formulas assume (half of the lateral
//!   load on the inclined bonds): Cu = 4·Fs0/(d²(1 − √3·μp)), I = σ1/σ3 at failure without
//!   cohesion = (3 + √3·μp)/(2(1 − √3·μp)), μi = (I − 1)/(2√I).
//!
//! Valid for 0 ≤ ν ≤ 1/3 (Ks ≥ 0) and μi ≥ 1/(2√6) ≈ 0.204 (μp ≥ 0).

use crate::error::{Error, Result};
use crate::materials::{check_common, MacroProperties, Material, MicroParameters};

const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// The largest ν a bonded hexagonal lattice gives (Ks = 0).
pub const MAX_POISSON_2D: f64 = 1.0 / 3.0;

/// The smallest μi the 2D formulas give (μp = 0, I = 3/2).
pub fn min_internal_friction_2d() -> f64 {
    0.5 / (2.0 * 1.5f64.sqrt())
}

/// Macro → micro for a 2D model of element diameter `d` (m), thickness d. Errors outside
/// 0 ≤ ν ≤ 1/3 and μi ≥ 0.204, with what to give instead.
pub fn macro_to_micro_2d(p: &MacroProperties, d: f64) -> Result<MicroParameters> {
    check_common(p, d)?;
    if !p.poisson.is_finite() || p.poisson < 0.0 || p.poisson > MAX_POISSON_2D {
        return Err(Error::param(
            "nu",
            p.poisson,
            "the 2D lattice formulas need 0 ≤ ν ≤ 1/3 (above 1/3 the shear spring Ks would be negative); \
             use ν ≤ 1/3 and train the material, or give micro values directly",
        ));
    }
    let min_mu = min_internal_friction_2d();
    if !p.internal_friction.is_finite() || p.internal_friction < min_mu - 1e-12 {
        return Err(Error::param(
            "mu_i",
            p.internal_friction,
            format!(
                "the 2D lattice formulas need μi ≥ 1/(2√6) ≈ {min_mu:.3} (below it μp would be negative); \
                 use μi ≥ 0.205 or give micro values directly"
            ),
        ));
    }
    let (e, nu) = (p.young, p.poisson);
    let kn = e * d / (SQRT_3 * (1.0 - nu));
    let ks = (e * d * (1.0 - 3.0 * nu) / (SQRT_3 * (1.0 - nu * nu))).max(0.0);
    let xb = p.tensile * d * d * (2.0 * kn + ks) / (2.0 * SQRT_3 * kn * (kn + ks));
    let mui = p.internal_friction;
    let i = ((1.0 + mui * mui).sqrt() + mui).powi(2);
    let mu_p = ((2.0 * i - 3.0) / (SQRT_3 * (1.0 + 2.0 * i))).max(0.0);
    let fs0 = (1.0 - SQRT_3 * mu_p) * p.compressive * d * d / 4.0;
    for (name, v) in [("Kn", kn), ("Ks", ks), ("Xb", xb), ("Fs0", fs0)] {
        if !v.is_finite() {
            return Err(Error::param(
                "d",
                d,
                format!("with E = {:e} Pa gives {name} = {v}: give d in metres (the element diameter)", p.young),
            ));
        }
    }
    Ok(MicroParameters { kn, ks, xb, fs0, mu_p })
}

impl Material {
    /// A material for a 2D model (one layer of elements of diameter `d`, thickness d) from
    /// macro properties through the hexagonal lattice's conversion.
    pub fn from_macro_2d(name: &str, density: f64, p: &MacroProperties, d: f64) -> Result<Self> {
        let formulas = "2D hexagonal lattice formulas (docs/physics.md, 2D models)";
        Self::converted(name, density, p, d, macro_to_micro_2d(p, d), formulas)
    }
}

/// Micro → macro for a 2D model, the exact inverse of [`macro_to_micro_2d`].
pub fn micro_to_macro_2d(m: &MicroParameters, d: f64) -> MacroProperties {
    let (kn, ks) = (m.kn, m.ks);
    let young = 2.0 * SQRT_3 * kn * (kn + ks) / (d * (3.0 * kn + ks));
    let poisson = (kn - ks) / (3.0 * kn + ks);
    let tensile = 2.0 * SQRT_3 * kn * (kn + ks) * m.xb / (d * d * (2.0 * kn + ks));
    let compressive = 4.0 * m.fs0 / (d * d * (1.0 - SQRT_3 * m.mu_p));
    let i = (3.0 + SQRT_3 * m.mu_p) / (2.0 * (1.0 - SQRT_3 * m.mu_p));
    let internal_friction = (i - 1.0) / (2.0 * i.sqrt());
    MacroProperties { young, poisson, tensile, compressive, internal_friction }
}

/// The 2D properties of a 3D material held in plane strain (a slice of a long body, MatDEM's
/// `macro3Dto2D` as we read it): E' = E/(1 − ν²), ν' = ν/(1 − ν); strengths and μi kept. A 2D
/// model is a plate in plane stress: give it these to stand for a plane-strain section.
pub fn plane_strain_equivalent(p: &MacroProperties) -> MacroProperties {
    let nu = p.poisson;
    MacroProperties { young: p.young / (1.0 - nu * nu), poisson: nu / (1.0 - nu), ..*p }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        if b == 0.0 {
            a.abs()
        } else {
            ((a - b) / b).abs()
        }
    }

    #[test]
    fn conversion_2d_round_trips_to_1e12() {
        for (nu, mui) in [(0.0, 0.3), (0.1, 0.6), (0.25, 1.0), (1.0 / 3.0, 0.8)] {
            let p =
                MacroProperties { young: 3e10, poisson: nu, tensile: 6e6, compressive: 8e7, internal_friction: mui };
            let micro = macro_to_micro_2d(&p, 2e-3).unwrap();
            let back = micro_to_macro_2d(&micro, 2e-3);
            for (a, b) in [
                (back.young, p.young),
                (back.tensile, p.tensile),
                (back.compressive, p.compressive),
                (back.internal_friction, p.internal_friction),
            ] {
                assert!(rel(a, b) < 1e-12, "ν {nu}, μi {mui}: {a} against {b}");
            }
            assert!((back.poisson - nu).abs() < 1e-12);
        }
    }

    /// The central-force triangular lattice (Ks = 0) has ν = 1/3 and E = 2Kn/(√3·t), the
    /// textbook values of a triangular spring network.
    #[test]
    fn conversion_2d_gives_the_spring_network_values_without_shear_springs() {
        let m = MicroParameters { kn: 1e6, ks: 0.0, xb: 1e-6, fs0: 1.0, mu_p: 0.0 };
        let p = micro_to_macro_2d(&m, 1e-3);
        assert!(rel(p.poisson, 1.0 / 3.0) < 1e-15);
        assert!(rel(p.young, 2.0 * 1e6 / (SQRT_3 * 1e-3)) < 1e-14);
        // μp = 0: σ1/σ3 = 3/2 at failure without cohesion.
        assert!(rel(p.internal_friction, min_internal_friction_2d()) < 1e-14);
    }

    /// Plane strain: a plate of the 2D properties under uniaxial stress σ strains as the 3D
    /// body held at ε_yy = 0 does: ε_xx = σ(1 − ν²)/E, ε_zz = −σν(1 + ν)/E.
    #[test]
    fn the_plane_strain_equivalent_strains_as_the_held_3d_body() {
        let p = MacroProperties { young: 3e10, poisson: 0.2, tensile: 6e6, compressive: 8e7, internal_friction: 0.7 };
        let q = plane_strain_equivalent(&p);
        let (e, nu, sigma) = (p.young, p.poisson, 1e6);
        // 3D, ε_yy = 0: σ_yy = ν·σ; ε_xx = (σ − ν·σ_yy)/E, ε_zz = −ν(σ + σ_yy)/E.
        let (exx, ezz) = ((sigma - nu * nu * sigma) / e, -nu * (sigma + nu * sigma) / e);
        assert!(rel(sigma / q.young, exx) < 1e-14 && rel(-q.poisson * sigma / q.young, ezz) < 1e-14);
        assert_eq!((q.tensile, q.compressive, q.internal_friction), (p.tensile, p.compressive, p.internal_friction));
    }

    #[test]
    fn conversion_2d_refuses_poisson_above_a_third_and_low_friction() {
        let mut p =
            MacroProperties { young: 2e10, poisson: 0.34, tensile: 5e6, compressive: 5e7, internal_friction: 0.6 };
        let e = macro_to_micro_2d(&p, 1e-3).unwrap_err().to_string();
        assert!(e.contains("1/3") && e.contains("negative"), "{e}");
        p.poisson = 0.25;
        p.internal_friction = 0.2;
        let e = macro_to_micro_2d(&p, 1e-3).unwrap_err().to_string();
        assert!(e.contains("0.204") && e.contains("μp"), "{e}");
        // A 2D material may have ν above the 3D formulas' 0.2.
        p.internal_friction = 0.6;
        assert!(macro_to_micro_2d(&p, 1e-3).unwrap().ks > 0.0);
    }
}
