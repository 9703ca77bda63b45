//! Materials: MatDEM's micro parameters per element, and the macro ↔ micro conversion of
//! paper 003, appendix A (close-packed lattice loaded normal to its close-packed planes).

use crate::error::{check_positive, Error, Result};
use crate::provenance::{Provenance, Source};
use serde::{Deserialize, Serialize};
use std::f64::consts::SQRT_2;

/// Most materials a scene may hold: the plan's pair table has M² entries (256 materials:
/// 65 536 pairs, 4.7 MB on the CPU, 3.1 MB on the GPU), read by every contact; more would
/// spill the caches the contact pass lives in.
pub const MAX_MATERIALS: usize = 256;

/// Macro properties of a rock or soil, the input of the conversion formulas.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MacroProperties {
    /// Young's modulus E (Pa).
    pub young: f64,
    /// Poisson's ratio ν; the lattice formulas hold for 0 ≤ ν ≤ 0.2.
    pub poisson: f64,
    /// Uniaxial tensile strength Tu (Pa).
    pub tensile: f64,
    /// Uniaxial compressive strength Cu (Pa).
    pub compressive: f64,
    /// Internal friction coefficient μi; the formulas need μi ≥ 1/(2√2) ≈ 0.354.
    pub internal_friction: f64,
}

/// Micro parameters of one element type (MatDEM's `Kn, Ks, Xb, Fs0, μp`).
///
/// `kn`, `ks` are the spring constants between two elements of this material (what the
/// conversion formulas give). Each element carries twice that, so that two identical elements
/// in series give back `kn`, and a rigid wall against one element sees `2·kn`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub name: String,
    /// Density (kg/m³).
    pub density: f64,
    /// Normal spring constant between two elements (N/m).
    pub kn: f64,
    /// Shear spring constant between two elements (N/m).
    pub ks: f64,
    /// Breaking displacement in tension (m); 0 means bonds break at any tension.
    pub xb: f64,
    /// Initial shear resistance of an intact bond (N).
    pub fs0: f64,
    /// Inter-particle friction coefficient μp.
    pub mu_p: f64,
    /// Young's modulus for the Hertz normal law (Pa).
    pub young: f64,
    /// Poisson's ratio for the Hertz normal law.
    pub poisson: f64,
    /// Coefficient of restitution of the normal contact dashpot; 1 means no dashpot.
    pub restitution: f64,
    /// Where each value came from (given, derived, default, trained), for `print(m)`. Not
    /// part of the material's own serialisation: checkpoints carry it beside the model, and a
    /// trained material file says what it was trained for in its own fields.
    #[serde(skip)]
    pub provenance: Provenance,
}

/// The micro values, as scripts name them.
const MICRO: [&str; 5] = ["kn", "ks", "xb", "fs0", "mu_p"];

impl Material {
    /// A material from micro values. Hertz constants default to E = Kn/(π·R) at `radius`
    /// with ν = 0 (paper 000, eq. 6–7); no dashpot.
    pub fn from_micro(
        name: &str,
        density: f64,
        kn: f64,
        ks: f64,
        xb: f64,
        fs0: f64,
        mu_p: f64,
        radius: f64,
    ) -> Result<Self> {
        // E = Kn/(πR) needs the element radius: name it, not the modulus it would spoil.
        if !(radius.is_finite() && radius > 0.0) {
            return Err(Error::InvalidMaterial {
                material: name.to_string(),
                reason: format!(
                    "`r` = {radius}: the element radius must be a finite number > 0 (it sets E = Kn/(πR) for Hertz)"
                ),
            });
        }
        let micro = MicroParameters { kn, ks, xb, fs0, mu_p };
        let mut m = Material::from_micro_hertz(name, density, &micro, kn / (std::f64::consts::PI * radius), 0.0)?;
        let p = &mut m.provenance;
        p.set("young", Source::Derived(format!("E = Kn/(πR) at R = {radius:.4e} m (paper 000, eq. 6)")));
        p.set("poisson", Source::Default("0, paper 000's Hertz convention; give `poisson` to set it".into()));
        Ok(m)
    }

    /// A material from micro values with its Hertz constants E and ν given directly.
    pub fn from_micro_hertz(
        name: &str,
        density: f64,
        micro: &MicroParameters,
        young: f64,
        poisson: f64,
    ) -> Result<Self> {
        let mut m = Material {
            name: name.to_string(),
            density,
            kn: micro.kn,
            ks: micro.ks,
            xb: micro.xb,
            fs0: micro.fs0,
            mu_p: micro.mu_p,
            young,
            poisson,
            restitution: 1.0,
            provenance: Provenance::default(),
        };
        m.validate()?;
        let p = &mut m.provenance;
        p.set_all(&["density"], Source::Given);
        p.set_all(&MICRO, Source::Given);
        p.set_all(&["young", "poisson"], Source::Given);
        p.set("restitution", Source::Default("1, no contact dashpot".into()));
        Ok(m)
    }

    /// A material from macro properties through the lattice conversion (paper 003, app. A),
    /// for elements of diameter `d`. Hertz constants are the macro E and ν.
    pub fn from_macro(name: &str, density: f64, p: &MacroProperties, d: f64) -> Result<Self> {
        Self::converted(name, density, p, d, macro_to_micro(p, d), "lattice formulas (paper 003, app. A)")
    }

    /// A material from micro values a conversion gave (or its error), with their provenance.
    pub(crate) fn converted(
        name: &str,
        density: f64,
        p: &MacroProperties,
        d: f64,
        micro: Result<MicroParameters>,
        formulas: &str,
    ) -> Result<Self> {
        let micro = micro.map_err(|e| Error::InvalidMaterial { material: name.to_string(), reason: e.to_string() })?;
        let m = Material {
            name: name.to_string(),
            density,
            kn: micro.kn,
            ks: micro.ks,
            xb: micro.xb,
            fs0: micro.fs0,
            mu_p: micro.mu_p,
            young: p.young,
            poisson: p.poisson,
            restitution: 1.0,
            provenance: Provenance::default(),
        };
        m.validate()?;
        let mut m = m;
        let how = format!(
            "{formulas} from E {:.4e} Pa, ν {}, Tu {:.4e} Pa, Cu {:.4e} Pa, μi {} at d = {d:.4e} m",
            p.young, p.poisson, p.tensile, p.compressive, p.internal_friction
        );
        m.provenance.set_all(&["density", "young", "poisson"], Source::Given);
        m.provenance.set_all(&MICRO, Source::Derived(how));
        m.provenance.set("restitution", Source::Default("1, no contact dashpot".into()));
        Ok(m)
    }

    /// Refuses non-finite, negative or out-of-range values, naming the field.
    pub fn validate(&self) -> Result<()> {
        let wrap = |e: Error| Error::InvalidMaterial { material: self.name.clone(), reason: e.to_string() };
        check_positive("density", self.density, false).map_err(wrap)?;
        check_positive("kn", self.kn, false).map_err(wrap)?;
        check_positive("ks", self.ks, true).map_err(wrap)?;
        check_positive("xb", self.xb, true).map_err(wrap)?;
        check_positive("fs0", self.fs0, true).map_err(wrap)?;
        check_positive("mu_p", self.mu_p, true).map_err(wrap)?;
        check_positive("young", self.young, false).map_err(wrap)?;
        if !(0.0..0.5).contains(&self.poisson) {
            return Err(wrap(Error::param("poisson", self.poisson, "must be in [0, 0.5)")));
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(wrap(Error::param(
                "restitution",
                self.restitution,
                "must be in [0, 1] (1 = elastic, 0 = no rebound)",
            )));
        }
        Ok(())
    }

    /// Its micro values, as the conversion formulas take them.
    pub fn micro(&self) -> MicroParameters {
        MicroParameters { kn: self.kn, ks: self.ks, xb: self.xb, fs0: self.fs0, mu_p: self.mu_p }
    }

    /// The macro properties this material has on an ideal lattice of diameter `d`.
    pub fn lattice_macro(&self, d: f64) -> MacroProperties {
        micro_to_macro(&self.micro(), d)
    }

    /// Rescales to elements of diameter `d_new` from `d_old`, keeping Kn/d, Kn/Ks and the
    /// lattice strengths (paper 001 §2: stiffness ∝ d, forces ∝ d², breaking displacement ∝ d).
    pub fn rescaled(&self, d_old: f64, d_new: f64) -> Result<Self> {
        check_positive("d_old", d_old, false)?;
        check_positive("d_new", d_new, false)?;
        let s = d_new / d_old;
        let mut m = self.clone();
        m.kn *= s;
        m.ks *= s;
        m.xb *= s;
        m.fs0 *= s * s;
        m.young = self.young; // E is a continuum property; for E = Kn/(πR) it is scale-free too
        if s != 1.0 {
            for (key, law) in [("kn", "∝ d"), ("ks", "∝ d"), ("xb", "∝ d"), ("fs0", "∝ d²")] {
                let mut how = format!("rescaled from d = {d_old:.4e} m to {d_new:.4e} m ({law}, paper 001 §2)");
                if let Some(before) = self.provenance.of(key).filter(|s| **s != Source::Given) {
                    how.push_str(&format!(" from a value {before}"));
                }
                m.provenance.set(key, Source::Derived(how));
            }
        }
        Ok(m)
    }
}

/// The Young's moduli, in Pa, the lattice conversion takes: from a soft gel to beyond diamond.
pub const YOUNG_RANGE: (f64, f64) = (1.0, 1e14);

/// Micro parameters as the conversion formulas produce them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MicroParameters {
    pub kn: f64,
    pub ks: f64,
    pub xb: f64,
    pub fs0: f64,
    pub mu_p: f64,
}

/// What every lattice conversion refuses, in 3D and 2D: E, Tu, Cu, d not finite or negative,
/// E outside [`YOUNG_RANGE`], Tu above Cu.
pub(crate) fn check_common(p: &MacroProperties, d: f64) -> Result<()> {
    check_positive("E", p.young, false)?;
    check_positive("Tu", p.tensile, true)?;
    check_positive("Cu", p.compressive, true)?;
    check_positive("d", d, false)?;
    // Outside these the conversion's products under- or overflow (E = 1e-300 gave Xb = inf,
    // E = 1e300 gave Xb = 0) and the error would name a derived value instead of the input.
    if !(YOUNG_RANGE.0..=YOUNG_RANGE.1).contains(&p.young) {
        return Err(Error::param(
            "E",
            p.young,
            format!(
                "is outside {:e} to {:e} Pa, where no rock or soil lies; give E in Pa",
                YOUNG_RANGE.0, YOUNG_RANGE.1
            ),
        ));
    }
    if p.tensile > p.compressive {
        return Err(Error::param(
            "Tu",
            p.tensile,
            format!(
                "is above Cu = {:e} Pa: a rock or soil is weaker in tension than in compression (Tu is typically \
                 Cu/8 to Cu/20); check that the two are not swapped",
                p.compressive
            ),
        ));
    }
    Ok(())
}

/// Macro → micro (paper 003, app. A). Errors outside 0 ≤ ν ≤ 0.2 and μi ≥ 1/(2√2).
pub fn macro_to_micro(p: &MacroProperties, d: f64) -> Result<MicroParameters> {
    check_common(p, d)?;
    if !p.poisson.is_finite() || p.poisson < 0.0 || p.poisson > 0.2 {
        return Err(Error::param(
            "nu",
            p.poisson,
            "the lattice formulas need 0 ≤ ν ≤ 0.2 (above 0.2 the shear spring Ks would be negative); \
             use ν ≤ 0.2 and train the material, or give micro values directly",
        ));
    }
    let min_mu = 1.0 / (2.0 * SQRT_2);
    if !p.internal_friction.is_finite() || p.internal_friction < min_mu - 1e-12 {
        return Err(Error::param(
            "mu_i",
            p.internal_friction,
            format!(
                "the lattice formulas need μi ≥ 1/(2√2) ≈ {min_mu:.3} (below it μp would be negative); \
                 use μi ≥ 0.354 or give micro values directly"
            ),
        ));
    }
    let (e, nu) = (p.young, p.poisson);
    let kn = SQRT_2 * e * d / (4.0 * (1.0 - 2.0 * nu));
    let ks = (SQRT_2 * (1.0 - 5.0 * nu) * e * d / (4.0 * (1.0 + nu) * (1.0 - 2.0 * nu))).max(0.0);
    let xb = (3.0 * kn + ks) * p.tensile * d * d / (6.0 * SQRT_2 * kn * (kn + ks));
    let mui = p.internal_friction;
    let i = ((1.0 + mui * mui).sqrt() + mui).powi(2);
    let mu_p = ((-2.0 * SQRT_2 + SQRT_2 * i) / (2.0 + 2.0 * i)).max(0.0);
    let fs0 = (1.0 - SQRT_2 * mu_p) * p.compressive * d * d / 6.0;
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

/// Micro → macro (paper 003, app. A), the exact inverse of [`macro_to_micro`].
pub fn micro_to_macro(m: &MicroParameters, d: f64) -> MacroProperties {
    let (kn, ks) = (m.kn, m.ks);
    let young = 6.0 * SQRT_2 * kn * (kn + ks) / (d * (5.0 * kn + ks));
    let poisson = (kn - ks) / (5.0 * kn + ks);
    let tensile = 6.0 * SQRT_2 * kn * (kn + ks) * m.xb / (d * d * (3.0 * kn + ks));
    let compressive = 6.0 * m.fs0 / (d * d * (1.0 - SQRT_2 * m.mu_p));
    let i = (2.0 + SQRT_2 * m.mu_p) / (1.0 - SQRT_2 * m.mu_p);
    let internal_friction = (i - 1.0) / (2.0 * i.sqrt());
    MacroProperties { young, poisson, tensile, compressive, internal_friction }
}

/// Marks a material cloned by a per-element write: `base~k`.
pub const CLONE_MARK: char = '~';

/// The name a material had before per-element writes cloned it (`rock` for `rock~3`).
pub fn base_name(name: &str) -> &str {
    clone_parts(name).map_or(name, |(base, _)| base)
}

/// `(base, k)` of a clone's name `base~k`; `None` for any other name.
pub(crate) fn clone_parts(name: &str) -> Option<(&str, &str)> {
    name.rsplit_once(CLONE_MARK).filter(|(_, k)| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
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
    fn conversion_matches_worked_table_sandstone_and_granite() {
        // physics.md §3 (7 significant figures in the table → 1e-6 relative).
        let sand = macro_to_micro(
            &MacroProperties { young: 2e10, poisson: 0.2, tensile: 5e6, compressive: 5e7, internal_friction: 0.6 },
            1e-3,
        )
        .unwrap();
        assert!(rel(sand.kn, 1.178511e7) < 1e-6);
        assert!(sand.ks.abs() < 1e-6);
        assert!(rel(sand.xb, 1.5e-7) < 1e-6);
        assert!(rel(sand.fs0, 6.06880) < 1e-5);
        assert!(rel(sand.mu_p, 0.192152) < 1e-5);
        let gran = macro_to_micro(
            &MacroProperties { young: 5e10, poisson: 0.15, tensile: 1e7, compressive: 1.5e8, internal_friction: 1.0 },
            2e-3,
        )
        .unwrap();
        assert!(rel(gran.kn, 5.050763e7) < 1e-6);
        assert!(rel(gran.ks, 1.097992e7) < 1e-6);
        assert!(rel(gran.xb, 2.466667e-7) < 1e-6);
        assert!(rel(gran.fs0, 43.934) < 1e-4);
        assert!(rel(gran.mu_p, 0.396447) < 1e-5);
    }

    #[test]
    fn conversion_round_trip_to_1e9() {
        for p in [
            MacroProperties { young: 2e10, poisson: 0.2, tensile: 5e6, compressive: 5e7, internal_friction: 0.6 },
            MacroProperties { young: 5e10, poisson: 0.15, tensile: 1e7, compressive: 1.5e8, internal_friction: 1.0 },
            MacroProperties { young: 5e7, poisson: 0.15, tensile: 2e4, compressive: 2e5, internal_friction: 0.6 },
            MacroProperties { young: 1e9, poisson: 0.0, tensile: 1e5, compressive: 1e6, internal_friction: 0.354 },
        ] {
            for d in [1e-3, 2e-3, 0.05] {
                let back = micro_to_macro(&macro_to_micro(&p, d).unwrap(), d);
                assert!(rel(back.young, p.young) < 1e-9);
                assert!((back.poisson - p.poisson).abs() < 1e-9);
                assert!(rel(back.tensile, p.tensile) < 1e-9);
                assert!(rel(back.compressive, p.compressive) < 1e-9);
                assert!(rel(back.internal_friction, p.internal_friction) < 1e-9);
            }
        }
    }

    #[test]
    fn conversion_refuses_poisson_above_0_2_and_low_friction() {
        let mut p =
            MacroProperties { young: 2e10, poisson: 0.25, tensile: 5e6, compressive: 5e7, internal_friction: 0.6 };
        let e = macro_to_micro(&p, 1e-3).unwrap_err().to_string();
        assert!(e.contains("0.2") && e.contains("negative"), "{e}");
        p.poisson = 0.1;
        p.internal_friction = 0.3;
        let e = macro_to_micro(&p, 1e-3).unwrap_err().to_string();
        assert!(e.contains("0.354"), "{e}");
        p.internal_friction = 0.6;
        p.tensile = -1.0;
        assert!(macro_to_micro(&p, 1e-3).is_err());
        p.tensile = f64::NAN;
        assert!(macro_to_micro(&p, 1e-3).is_err());
    }

    #[test]
    fn rescaled_material_keeps_kn_over_d_and_lattice_strength() {
        let p =
            MacroProperties { young: 5e10, poisson: 0.15, tensile: 1e7, compressive: 1.5e8, internal_friction: 1.0 };
        let m = Material::from_macro("granite", 2650.0, &p, 2e-3).unwrap();
        let r = m.rescaled(2e-3, 8e-3).unwrap();
        assert!(rel(r.kn / 8e-3, m.kn / 2e-3) < 1e-12);
        assert!(rel(r.kn / r.ks, m.kn / m.ks) < 1e-12);
        let back = r.lattice_macro(8e-3);
        assert!(rel(back.young, p.young) < 1e-9 && rel(back.tensile, p.tensile) < 1e-9);
        assert!(rel(back.compressive, p.compressive) < 1e-9);
    }
}
