//! The scene's choice of contact laws, as values (`NormalKind`, `TangentialKind`: what a
//! script sets and a checkpoint saves), and the one place a choice becomes its law: each
//! method below asks the law's type ([`NormalLaw`], [`TangentialLaw`]), so the guard, the
//! energies, the model, the plan, the scaling and the GPU's shader constants never switch on a
//! kind themselves. A new law
//! is its type, one variant and one arm in each macro here. Hot loops take the law as a type
//! parameter instead ([`with_laws!`](crate::with_laws)).

use super::contact_law::{
    Hertz, Linear, LinearShear, MindlinDampedShear, MindlinShear, NormalLaw, PairParams, TangentialLaw,
};
use crate::error::{Error, Result};
use crate::materials::Material;
use serde::{Deserialize, Serialize};
use std::str::FromStr;

/// The compressive normal law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum NormalKind {
    /// Kn·δ (MatDEM's default).
    Linear,
    /// (4/3)·E*·√R*·δ^(3/2), from each material's E and ν (paper 000: E = Kn/(πR), ν = 0).
    Hertz,
}

/// The shear spring.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum TangentialKind {
    /// Constant Ks (MatDEM).
    Linear,
    /// Mindlin's 8·G*·√(R*·δ).
    Mindlin,
    /// Mindlin's spring with a tangential dashpot from the restitution (LIGGGHTS'
    /// `tangential_damping on`), capped at μ·Fn together.
    MindlinDamped,
}

/// `$body` with `$law` the type of the normal law `$kind` names.
macro_rules! normal_law {
    ($kind:expr, $law:ident => $body:expr) => {
        match $kind {
            NormalKind::Linear => {
                type $law = Linear;
                $body
            }
            NormalKind::Hertz => {
                type $law = Hertz;
                $body
            }
        }
    };
}

/// `$body` with `$law` the type of the tangential law `$kind` names.
macro_rules! tangential_law {
    ($kind:expr, $law:ident => $body:expr) => {
        match $kind {
            TangentialKind::Linear => {
                type $law = LinearShear;
                $body
            }
            TangentialKind::Mindlin => {
                type $law = MindlinShear;
                $body
            }
            TangentialKind::MindlinDamped => {
                type $law = MindlinDampedShear;
                $body
            }
        }
    };
}

impl NormalKind {
    pub const ALL: [NormalKind; 2] = [NormalKind::Linear, NormalKind::Hertz];

    /// The name scripts and plans use.
    pub fn name(self) -> &'static str {
        normal_law!(self, L => L::NAME)
    }

    /// Elastic normal force at overlap δ > 0.
    pub fn force(self, p: &PairParams, r_star: f64, overlap: f64) -> f64 {
        normal_law!(self, L => L::force(p, r_star, overlap))
    }

    /// Tangent stiffness at overlap δ > 0, and what the guard calls it.
    pub fn stiffness(self, p: &PairParams, r_star: f64, overlap: f64) -> (f64, &'static str) {
        normal_law!(self, L => (L::stiffness(p, r_star, overlap), L::STIFFNESS))
    }

    /// An element's stiffest likely contact ([`NormalLaw::element_stiffness`]).
    pub fn element_stiffness(self, material: &Material, r: f64) -> f64 {
        normal_law!(self, L => L::element_stiffness(material, r))
    }

    /// [`NormalLaw::FORCE_POWER`].
    pub fn force_power(self) -> i32 {
        normal_law!(self, L => L::FORCE_POWER)
    }

    /// [`NormalLaw::GPU`].
    pub fn gpu_switches(self) -> [(&'static str, bool); 1] {
        normal_law!(self, L => L::GPU)
    }
}

impl TangentialKind {
    pub const ALL: [TangentialKind; 3] =
        [TangentialKind::Linear, TangentialKind::Mindlin, TangentialKind::MindlinDamped];

    /// The name scripts use.
    pub fn name(self) -> &'static str {
        tangential_law!(self, T => T::NAME)
    }

    /// How a plan describes it.
    pub fn description(self) -> &'static str {
        tangential_law!(self, T => T::DESCRIPTION)
    }

    /// The shear stiffness at overlap δ, and what the guard calls it.
    pub fn stiffness(self, p: &PairParams, r_star: f64, overlap: f64) -> (f64, &'static str) {
        tangential_law!(self, T => (T::stiffness(p, r_star, overlap), T::STIFFNESS))
    }

    /// [`TangentialLaw::FORCE_POWER`].
    pub fn force_power(self) -> i32 {
        tangential_law!(self, T => T::FORCE_POWER)
    }

    /// [`TangentialLaw::GPU`].
    pub fn gpu_switches(self) -> [(&'static str, bool); 2] {
        tangential_law!(self, T => T::GPU)
    }

    /// Whether a tangential dashpot acts ([`TangentialLaw::DAMPED`]).
    pub fn damped(self) -> bool {
        tangential_law!(self, T => T::DAMPED)
    }

    /// Mindlin's stiffness, with or without the dashpot: the shear force grows as λ² under
    /// scaling.
    pub fn is_mindlin(self) -> bool {
        self.force_power() == 2
    }
}

impl FromStr for NormalKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let known = NormalKind::ALL.map(NormalKind::name);
        NormalKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| Error::unknown("normal contact law", s, &known))
    }
}

impl FromStr for TangentialKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let known = TangentialKind::ALL.map(TangentialKind::name);
        TangentialKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| Error::unknown("tangential contact law", s, &known))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_law_is_found_by_its_name_and_an_unknown_name_lists_them() {
        for k in NormalKind::ALL {
            assert_eq!(k.name().parse::<NormalKind>().unwrap(), k);
        }
        for k in TangentialKind::ALL {
            assert_eq!(k.name().parse::<TangentialKind>().unwrap(), k);
        }
        let Err(Error::Unknown { suggestion, known, .. }) = "herz".parse::<NormalKind>() else { panic!() };
        assert_eq!((suggestion.as_deref(), known), (Some("hertz"), vec!["linear".to_string(), "hertz".to_string()]));
        let Err(Error::Unknown { suggestion, known, .. }) = "mindlin_dampd".parse::<TangentialKind>() else { panic!() };
        assert_eq!((suggestion.as_deref(), known.len()), (Some("mindlin_damped"), 3));
    }

    #[test]
    fn scaling_powers_follow_the_laws_stiffness() {
        // A linear spring's force grows as the overlap (λ); Hertz's and Mindlin's stiffness grow
        // with √(R·δ), so their forces as λ².
        let p = PairParams { kn: 1e6, ks: 4e5, e_star: 1e9, g_star: 4e8, ..PairParams::default() };
        let (r, d, l) = (1e-3, 1e-5, 3.0);
        for k in NormalKind::ALL {
            let ratio = k.force(&p, r * l, d * l) / k.force(&p, r, d);
            assert!((ratio / l.powi(k.force_power()) - 1.0).abs() < 1e-12, "{k:?}: {ratio}");
        }
        for k in TangentialKind::ALL {
            // Shear force = stiffness × displacement, the displacement grown by λ too.
            let ratio = k.stiffness(&p, r * l, d * l).0 * l / k.stiffness(&p, r, d).0;
            assert!((ratio / l.powi(k.force_power()) - 1.0).abs() < 1e-12, "{k:?}: {ratio}");
        }
    }
}
