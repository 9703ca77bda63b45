//! The body forces' potential energy — gravity's and the water table's buoyancy's — and the
//! work done on the model by changing them between runs (lowering or raising the table,
//! changing the fluid's density or gravity), for the energy account ([`crate::status`]).
//!
//! **The buoyant potential.** An element below the level L feels F_z = −g_z·ρ_f·V_sub(z)
//! (`physics::buoyancy`; g_z < 0, so it pushes up), with V_sub the submerged volume of its
//! sphere, which depends on its height z only. Its potential, zero where the element is dry
//! and growing with depth, is
//!
//! ```text
//! U_b(z) = −g_z·ρ_f·∫_z^∞ V_sub(z′) dz′ = −g_z·ρ_f·I(h),   h = L + r − z (the cap's height),
//!
//! I(h) = π·(r·h³/3 − h⁴/12)      for 0 ≤ h ≤ 2r (the cap),
//! I(h) = V·(h − r) = V·(L − z)   for h ≥ 2r (submerged: ρ_f·|g|·V times the centre's depth),
//! ```
//!
//! so that −dU_b/dz is the buoyant force, cap included. (The same potential, up to a constant
//! that depends on L, as the displaced water's ρ_f·V·g_z·z with a negative mass.) Only the
//! vertical component has a potential: with a gravity that is not vertical, the buoyancy's
//! horizontal part −g_x·ρ_f·V_sub(z) depends on the depth and its work is not a potential's (the
//! account does not close then). Killed elements feel no buoyancy and hold none.
//!
//! **Changing the fields.** Setting the level (or the density, or gravity) changes the
//! elements' potential where they stand: that change is work done on the model from outside,
//! as a moving wall's is. The model keeps the fields the account last saw; when they differ
//! (a script set them between runs), the difference of the body potential at the current
//! positions, new fields minus old, is booked as [`BodyWork::work`], and the account's total
//! (mechanical + heat − wall work − body work) carries on. Lowering the table takes potential
//! away from the submerged elements (negative work: the ground then settles and the elastic
//! energy and heat it gains come out of it). The booking is made by the script's setters
//! before the fields change and again after, and by every run before it steps, so a program
//! that writes `settings` directly is booked at its next run or energy reading (at the
//! positions then, which a run has not moved yet). Saved in a checkpoint (format 8), the fields
//! seen with the work, so that a loaded model's account closes as the saved one's would; an
//! older file loads with no work booked and the fields it holds as the ones seen.

use crate::model::Model;
pub use crate::state::body_work::{BodyFields, BodyWork};

/// ∫_0^h V_cap(h′) dh′ for a sphere of radius `r` (m⁴): the buoyant potential over ρ_f·|g_z|
/// of an element whose cap below the level is `h` high (h ≥ 2r: submerged).
#[inline]
pub fn submerged_integral(h: f64, r: f64) -> f64 {
    use std::f64::consts::PI;
    if h <= 0.0 {
        0.0
    } else if h <= 2.0 * r {
        PI * (r * h * h * h / 3.0 - h * h * h * h / 12.0)
    } else {
        4.0 / 3.0 * PI * r * r * r * (h - r)
    }
}

/// The buoyant potential (J) of an element of radius `r` centred at height `z`: −g_z·ρ_f·I(h).
#[inline]
pub fn buoyant_potential(z: f64, r: f64, level: f64, density: f64, g_z: f64) -> f64 {
    -g_z * density * submerged_integral(level + r - z, r)
}

impl BodyFields {
    /// The fields as the model's settings have them now.
    pub fn of(m: &Model) -> Self {
        let w = &m.settings.water;
        BodyFields { gravity: m.settings.gravity, level: w.level, density: w.density }
    }

    /// Gravity's potential −Σ m·g·x over every element (killed ones hold still: a constant).
    pub fn gravity_potential(&self, m: &Model) -> f64 {
        let p = &m.particles;
        -(0..p.len()).map(|i| p.mass[i] * self.gravity.dot(&p.pos[i])).sum::<f64>()
    }

    /// The buoyant potential Σ U_b of the elements below the level (0 without water).
    pub fn buoyant_potential(&self, m: &Model) -> f64 {
        let Some(level) = self.level else { return 0.0 };
        let p = &m.particles;
        (0..p.len())
            .filter(|&i| !m.is_killed(i))
            .map(|i| buoyant_potential(p.pos[i].z, p.radius[i], level, self.density, self.gravity.z))
            .sum()
    }

    fn potential(&self, m: &Model) -> f64 {
        self.gravity_potential(m) + self.buoyant_potential(m)
    }
}

impl Model {
    /// The body work booked, plus what a change of the fields not yet booked would book now.
    pub fn body_work(&self) -> f64 {
        self.body_work.work + self.pending_body_work()
    }

    fn pending_body_work(&self) -> f64 {
        let now = BodyFields::of(self);
        match self.body_work.seen {
            Some(seen) if seen != now => now.potential(self) - seen.potential(self),
            _ => 0.0,
        }
    }

    /// Books the work of any change of gravity or the water table since the account last
    /// looked, at the current positions, and remembers the fields as they are now. Call it
    /// before and after changing them between runs (runs call it before stepping).
    pub fn book_body_work(&mut self) {
        let pending = self.pending_body_work();
        self.body_work.work += pending;
        self.body_work.seen = Some(BodyFields::of(self));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn the_buoyant_potential_is_the_integral_of_the_buoyant_force() {
        let (r, level, rho, gz) = (0.3, 1.0, 1000.0, -9.81);
        let v = 4.0 / 3.0 * PI * r * r * r;
        // Dry above the level + r; continuous at the cap's ends; ρ_f·g·V·depth when submerged.
        assert_eq!(buoyant_potential(level + r + 1e-9, r, level, rho, gz), 0.0);
        let deep = level - 2.0;
        assert!((buoyant_potential(deep, r, level, rho, gz) - rho * 9.81 * v * 2.0).abs() < 1e-9);
        let at = |h: f64| buoyant_potential(level + r - h, r, level, rho, gz);
        assert!((at(2.0 * r - 1e-12) - at(2.0 * r + 1e-12)).abs() < 1e-6);
        // −dU/dz is the buoyant force ρ_f·|g|·V_sub, by central differences through the cap.
        for h in [0.05, 0.2, 0.3, 0.45, 0.59, 0.9] {
            let z = level + r - h;
            let dz = 1e-6;
            let force = -(buoyant_potential(z + dz, r, level, rho, gz) - buoyant_potential(z - dz, r, level, rho, gz))
                / (2.0 * dz);
            let v_sub = crate::effects::buoyancy::physics::submerged_volume(z, r, level);
            assert!(
                (force - rho * 9.81 * v_sub).abs() < 1e-6 * rho * 9.81 * v,
                "h {h}: {force} vs {}",
                rho * 9.81 * v_sub
            );
        }
    }
}
