//! Moisture between two elements and its coupling to the mechanics (paper 003 §3.3, after
//! Zhang, Xu, Liu et al. 2017, "drying cracking using multi-field coupling DEM").
//!
//! An element stands for grains and pores together and carries a gravimetric water content ω
//! (kg of water per kg of the element, dimensionless). Between two elements in contact the
//! water flows as paper 003 eq. 3 says, dM₁₂ = α_w·(ω₂ − ω₁)·A·dt: the pair's moisture
//! conductance is G = α_w·A (kg/s per unit of ω), with α_w the pair's moisture diffusivity
//! (kg/(m²·s); the series mean 2·α1·α2/(α1 + α2) of two materials) and A = π·a² the area of
//! the circle the water crosses: a the same contact radius heat flows through (the Hertz
//! radius √(R*·δ) of an overlap, at least the bond's neck β·min(r1, r2) for a bonded pair;
//! effects/conduction/physics.rs). An element's water capacity is its mass m: dω_i/dt = Σ G·(ω_j − ω_i)/m_i.
//!
//! Evaporation at a free surface is an exchange with the air through the element's exposed
//! cross-section: E_i = χ·π·r_i² towards an ambient water content ω_a (χ the transfer
//! coefficient, kg/(m²·s), in the units of α_w), so a drying element loses E_i·(ω_i − ω_a)
//! kg/s — the air acts as a neighbour held at ω_a.
//!
//! The coupling is by tables the script gives (piecewise-linear in ω, held flat beyond their
//! ends): the radius r = r0·f_r(ω) (shrinkage on drying), and a bond's share of its material
//! pair's strength s(ω) ∈ (0, 1] at the pair's mean water content (strength rising as it dries:
//! the material's strength is the dry one).

use crate::effects::conduction::physics::contact_radius;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The moisture conductance G (kg/s per unit of water content) of elements with
/// diffusivities `ai`, `aj` (kg/(m²·s)) and radii `ri`, `rj` (m) at centre distance `dist` (m).
/// Symmetric in i and j, so what one element loses the other gains.
#[inline]
pub fn pair_moisture_conductance(ai: f64, aj: f64, ri: f64, rj: f64, dist: f64, bonded: bool, bond_radius: f64) -> f64 {
    let a = contact_radius(ri, rj, dist, bonded, bond_radius);
    if a > 0.0 && ai + aj > 0.0 {
        2.0 * ai * aj / (ai + aj) * PI * a * a
    } else {
        0.0
    }
}

/// The evaporation conductance E = χ·π·r² (kg/s per unit of water content) of an element of
/// radius `r` (m) exposed to the air with transfer coefficient `chi` (kg/(m²·s)).
#[inline]
pub fn evaporation_conductance(chi: f64, r: f64) -> f64 {
    chi * PI * r * r
}

/// A piecewise-linear function of the water content, given by points (ω, value) with ω
/// strictly increasing; held at the first value below the first point and at the last above.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Table {
    pub points: Vec<(f64, f64)>,
}

impl Table {
    /// A table from points, refused with the reason when it is not a function of ω or a
    /// value is outside `(lo, hi]`.
    pub fn new(points: Vec<(f64, f64)>, what: &str, lo: f64, hi: f64) -> Result<Self, String> {
        if points.is_empty() {
            return Err(format!("{what}: give at least one point [water content, value]"));
        }
        for (k, &(w, v)) in points.iter().enumerate() {
            if !w.is_finite() || !v.is_finite() {
                return Err(format!("{what}: point {k} [{w}, {v}] is not finite"));
            }
            if !(v > lo && v <= hi) {
                return Err(format!("{what}: point {k} has value {v}; values must lie in ({lo}, {hi}]"));
            }
            if k > 0 && w <= points[k - 1].0 {
                return Err(format!(
                    "{what}: water contents must increase from point to point; point {k} has {w} after {}",
                    points[k - 1].0
                ));
            }
        }
        Ok(Table { points })
    }

    /// The value at water content `w`.
    #[inline]
    pub fn at(&self, w: f64) -> f64 {
        let p = &self.points;
        if w <= p[0].0 {
            return p[0].1;
        }
        for k in 1..p.len() {
            if w <= p[k].0 {
                let (w0, v0) = p[k - 1];
                let (w1, v1) = p[k];
                return v0 + (v1 - v0) * (w - w0) / (w1 - w0);
            }
        }
        p[p.len() - 1].1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_interpolates_between_points_and_holds_beyond_its_ends() {
        let t = Table::new(vec![(0.0, 0.9), (0.2, 1.0)], "t", 0.0, 10.0).unwrap();
        assert_eq!(t.at(-1.0), 0.9);
        assert_eq!(t.at(0.5), 1.0);
        assert!((t.at(0.1) - 0.95).abs() < 1e-15);
        assert!(Table::new(vec![(0.2, 1.0), (0.1, 1.0)], "t", 0.0, 10.0).is_err());
        assert!(Table::new(vec![(0.2, 0.0)], "t", 0.0, 1.0).is_err());
        assert!(Table::new(vec![], "t", 0.0, 1.0).is_err());
    }

    #[test]
    fn the_moisture_conductance_is_the_diffusivity_times_the_contact_area() {
        // A bond's neck of 0.5·r: A = π·(r/2)².
        let g = pair_moisture_conductance(3.0, 3.0, 1.0, 1.0, 2.0, true, 0.5);
        assert!((g - 3.0 * PI * 0.25).abs() < 1e-14);
        assert_eq!(
            pair_moisture_conductance(1.0, 4.0, 1.0, 2.0, 2.9, false, 0.5),
            pair_moisture_conductance(4.0, 1.0, 2.0, 1.0, 2.9, false, 0.5)
        );
        assert_eq!(pair_moisture_conductance(1.0, 1.0, 1.0, 1.0, 2.1, false, 0.5), 0.0);
    }
}
