//! Rolling resistance: a torque that opposes the relative rolling of two bodies in contact, for
//! the `rolling_resistance` stage (effects/rolling_resistance/cpu.rs, shaders/rolling_resistance.wgsl).
//! Two models, as LIGGGHTS' `rolling_friction` (Ai, Chen, Rotter & Ooi 2011, Powder Technol.
//! 206: models A and C):
//!
//! - **cdt**, constant directional torque: M = −μ_r·R_eff·Fn·ω̂_t, where ω_t is the tangential
//!   part of the relative angular velocity ω_i − ω_j (its twist about the normal is left
//!   alone). No state.
//! - **epsd**, elastic–plastic spring–dashpot: a rolling spring M_k, incremented by
//!   −k_r·ω_t·dt with k_r = k_t·R_eff² (k_t the contact's tangential stiffness: LIGGGHTS'
//!   `epsd2` choice) and capped at μ_r·R_eff·Fn, plus a viscous torque −C_r·ω_t with
//!   C_r = 2·η_r·√(I_eff·k_r) while the spring is below its cap (none once fully mobilised,
//!   as LIGGGHTS' epsd). The spring is per-contact state, carried into the current tangent
//!   plane each step as the shear spring is, and dropped when the contact opens.
//!
//! R_eff = r_i·r_j/(r_i + r_j) (r_i against a wall), Fn the contact's elastic normal force
//! (≥ 0), I_eff = I_i·I_j/(I_i + I_j) (I_i against a wall). Every function here is odd in
//! (n, ω_rel, spring), so the two rows of a pair compute exactly opposite torques and keep
//! exactly opposite springs, as the contact law does (contact_law.rs).

use crate::physics::contact_law::rotate_into_plane;
use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// Which rolling resistance model a scene uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RollingModel {
    /// Constant directional torque (LIGGGHTS `rolling_friction cdt`).
    Cdt,
    /// Elastic–plastic spring–dashpot (LIGGGHTS `rolling_friction epsd2`'s stiffness).
    Epsd,
}

impl RollingModel {
    pub const fn name(self) -> &'static str {
        match self {
            RollingModel::Cdt => "cdt",
            RollingModel::Epsd => "epsd",
        }
    }

    /// The model of a script's name.
    pub fn parse(name: &str) -> Result<Self, String> {
        match name {
            "cdt" => Ok(RollingModel::Cdt),
            "epsd" => Ok(RollingModel::Epsd),
            other => Err(format!(
                "unknown rolling resistance model `{other}`: use \"cdt\" (constant directional torque) or \"epsd\" \
                 (elastic-plastic spring-dashpot)"
            )),
        }
    }
}

/// A scene's rolling resistance (one coefficient for every contact, walls included).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RollingResistance {
    pub model: RollingModel,
    /// Rolling resistance coefficient μ_r (dimensionless; the torque's cap is μ_r·R_eff·Fn).
    pub mu_r: f64,
    /// epsd's viscous damping ratio η_r (0 = none; LIGGGHTS' coefficientRollingViscousDamping).
    pub damping: f64,
}

impl RollingResistance {
    /// Checks the values: μ_r finite and ≥ 0, η_r finite and ≥ 0 (and 0 for cdt, which has no
    /// dashpot).
    pub fn new(model: RollingModel, mu_r: f64, damping: f64) -> Result<Self, String> {
        if !(mu_r.is_finite() && mu_r >= 0.0) {
            return Err(format!(
                "rolling resistance coefficient mu_r = {mu_r} is not a finite number ≥ 0: give e.g. mu_r: 0.1 (soils \
                 and sands take 0.05-0.3)"
            ));
        }
        if !(damping.is_finite() && damping >= 0.0) {
            return Err(format!(
                "rolling viscous damping ratio = {damping} is not a finite number ≥ 0: give e.g. damping: 0.3, or \
                 leave it out"
            ));
        }
        if model == RollingModel::Cdt && damping > 0.0 {
            return Err("the cdt model has no viscous part: leave damping out, or use model: \"epsd\"".into());
        }
        Ok(RollingResistance { model, mu_r, damping })
    }
}

/// One contact as the rolling resistance sees it from one element.
#[derive(Debug, Clone, Copy)]
pub struct RollingContact {
    /// Unit normal from this element towards the other body.
    pub n: Vec3,
    /// ω_i − ω_j (ω_i against a wall).
    pub w_rel: Vec3,
    /// R_eff (m).
    pub r_eff: f64,
    /// Elastic normal force, ≥ 0 (N).
    pub normal_force: f64,
    /// I_eff (kg·m²).
    pub inertia: f64,
}

impl RollingContact {
    /// The rolling part of the relative angular velocity: ω_rel less its twist about n.
    #[inline(always)]
    pub fn rolling(&self) -> Vec3 {
        self.w_rel - self.n * self.n.dot(&self.w_rel)
    }
}

/// I_eff of two elements, I_i·I_j/(I_i + I_j): symmetric in its arguments, bit for bit.
#[inline(always)]
pub fn pair_inertia(a: f64, b: f64) -> f64 {
    if a + b > 0.0 {
        a * b / (a + b)
    } else {
        0.0
    }
}

/// cdt's torque on this element: −μ_r·R_eff·Fn·ω̂_t, no larger than I_eff·|ω_t|/dt.
///
/// The cap: a constant torque is a Coulomb law in rotation, and with an explicit step a body
/// rolling slower than M·dt/I_eff per step would have its relative rotation reversed by one
/// step's torque, then pushed back the next: a chatter at rest, of amplitude M·dt/I_eff, that
/// does work on nothing. Capped, the step's torque at most brings ω_t to zero (LIGGGHTS has no
/// such cap; its chatter is why its docs advise epsd for packings at rest).
#[inline(always)]
pub fn cdt_torque(mu_r: f64, c: &RollingContact, dt: f64) -> Vec3 {
    let wt = c.rolling();
    let w2 = wt.norm_squared();
    if w2 == 0.0 || c.normal_force <= 0.0 {
        return Vec3::zeros();
    }
    let w = w2.sqrt();
    let m = (mu_r * c.r_eff * c.normal_force).min(c.inertia * w / dt);
    wt * (-m / w)
}

/// epsd's torque on this element: its rolling spring `spring` (updated in place: carried into
/// the current tangent plane, incremented by −k_r·ω_t·dt, capped at μ_r·R_eff·Fn) plus the
/// viscous torque −C_r·ω_t while the spring is below its cap. `kt` is the contact's tangential
/// stiffness (N/m), so that k_r = kt·R_eff².
#[inline(always)]
pub fn epsd_torque(r: &RollingResistance, c: &RollingContact, kt: f64, spring: &mut Vec3, dt: f64) -> Vec3 {
    let wt = c.rolling();
    let kr = kt * c.r_eff * c.r_eff;
    let mut s = rotate_into_plane(*spring, &c.n) - wt * (kr * dt);
    let limit = r.mu_r * c.r_eff * c.normal_force.max(0.0);
    let s2 = s.norm_squared();
    if s2 > limit * limit {
        // Fully mobilised: the spring slips at its cap and the dashpot is off.
        s *= limit / s2.sqrt();
        *spring = s;
        return s;
    }
    *spring = s;
    if r.damping > 0.0 {
        s - wt * (2.0 * r.damping * (c.inertia * kr).sqrt())
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact() -> RollingContact {
        RollingContact {
            n: Vec3::new(0.6, 0.0, 0.8),
            w_rel: Vec3::new(3.0, -2.0, 1.0),
            r_eff: 5e-4,
            normal_force: 2.0,
            inertia: 1e-9,
        }
    }

    #[test]
    fn cdt_opposes_rolling_and_ignores_twist() {
        let c = contact();
        let t = cdt_torque(0.1, &c, 1e-9);
        assert!(t.dot(&c.n).abs() < 1e-18, "no twisting torque");
        assert!(t.dot(&c.rolling()) < 0.0);
        assert!((t.norm() - 0.1 * 5e-4 * 2.0).abs() < 1e-15);
        let twist = RollingContact { w_rel: c.n * 4.0, ..c };
        assert_eq!(cdt_torque(0.1, &twist, 1e-6), Vec3::zeros());
    }

    #[test]
    fn cdt_never_reverses_the_rolling_in_one_step() {
        let c = RollingContact { w_rel: Vec3::new(0.0, 1e-6, 0.0), n: Vec3::z(), ..contact() };
        let dt = 1e-5;
        let t = cdt_torque(0.1, &c, dt);
        // Δω = M·dt/I_eff at most ω.
        assert!((t.norm() * dt / c.inertia - 1e-6).abs() < 1e-18);
    }

    #[test]
    fn both_rows_compute_opposite_torques() {
        let c = contact();
        let mirror = RollingContact { n: -c.n, w_rel: -c.w_rel, ..c };
        assert_eq!(cdt_torque(0.1, &mirror, 1e-6), -cdt_torque(0.1, &c, 1e-6));
        let r = RollingResistance::new(RollingModel::Epsd, 0.1, 0.3).unwrap();
        let (mut a, mut b) = (Vec3::new(1e-5, 2e-5, 0.0), Vec3::new(-1e-5, -2e-5, -0.0));
        for _ in 0..5 {
            let ta = epsd_torque(&r, &c, 1e4, &mut a, 1e-6);
            let tb = epsd_torque(&r, &mirror, 1e4, &mut b, 1e-6);
            assert_eq!(ta, -tb);
            assert_eq!(a, -b);
        }
    }

    #[test]
    fn epsd_spring_is_capped_at_mu_r_r_fn() {
        let r = RollingResistance::new(RollingModel::Epsd, 0.1, 0.0).unwrap();
        let c = contact();
        let mut s = Vec3::zeros();
        for _ in 0..1000 {
            epsd_torque(&r, &c, 1e6, &mut s, 1e-3);
        }
        assert!((s.norm() - 0.1 * 5e-4 * 2.0).abs() < 1e-15);
        // Elastic below the cap: −k_r·ω_t·dt.
        let mut s = Vec3::zeros();
        let t = epsd_torque(&r, &c, 1e3, &mut s, 1e-9);
        assert!((t + c.rolling() * (1e3 * 25e-8 * 1e-9)).norm() < 1e-25);
    }

    #[test]
    fn bad_values_are_refused_with_what_to_do() {
        assert!(RollingResistance::new(RollingModel::Cdt, -0.1, 0.0).unwrap_err().contains("mu_r: 0.1"));
        assert!(RollingResistance::new(RollingModel::Cdt, f64::NAN, 0.0).is_err());
        assert!(RollingResistance::new(RollingModel::Epsd, 0.1, f64::INFINITY).is_err());
        assert!(RollingResistance::new(RollingModel::Cdt, 0.1, 0.2).unwrap_err().contains("epsd"));
        assert!(RollingModel::parse("cdl").unwrap_err().contains("\"cdt\""));
    }
}
