//! Heat conduction between two elements: the pair conductance H (W/K) of a contact or a bond,
//! so that the heat flowing into element i from j is Q = H·(T_j − T_i) (paper 003 eq. 3's form,
//! reference/physics.md §4).
//!
//! Convention: Batchelor & O'Brien's constriction conductance of two spheres touching over a
//! circle of radius a, H = 4·a·k1·k2/(k1 + k2) (2·k·a for one material), with the Hertz contact
//! radius a = √(R*·δ) (R* = r1·r2/(r1 + r2), δ the overlap). A bonded pair conducts through
//! a neck of radius β·min(r1, r2) (β = `bond_radius`, the scene's choice), or through its contact
//! circle when that is larger. A pair that neither overlaps nor is bonded conducts nothing.

/// The conductance (W/K) of elements with conductivities `ki`, `kj` (W/(m·K)) and radii `ri`,
/// `rj` (m) at centre distance `dist` (m). Symmetric in i and j, so both rows of a pair see
/// the same H and the heat one element loses is the heat the other gains.
#[inline]
pub fn pair_conductance(ki: f64, kj: f64, ri: f64, rj: f64, dist: f64, bonded: bool, bond_radius: f64) -> f64 {
    let a = contact_radius(ri, rj, dist, bonded, bond_radius);
    if a > 0.0 && ki + kj > 0.0 {
        4.0 * a * ki * kj / (ki + kj)
    } else {
        0.0
    }
}

/// The radius (m) of the circle heat flows through: Hertz's √(R*·δ) for an overlap, at least
/// the bond's neck β·min(r1, r2) for a bonded pair, 0 otherwise.
#[inline]
pub fn contact_radius(ri: f64, rj: f64, dist: f64, bonded: bool, bond_radius: f64) -> f64 {
    let overlap = ri + rj - dist;
    let r_star = ri * rj / (ri + rj);
    let hertz = if overlap > 0.0 { (r_star * overlap).sqrt() } else { 0.0 };
    if bonded {
        hertz.max(bond_radius * ri.min(rj))
    } else {
        hertz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_material_gives_two_k_a_and_the_pair_is_symmetric() {
        // r = 1, δ = 0.01: R* = 0.5, a = √0.005.
        let a = (0.5f64 * 0.01).sqrt();
        let h = pair_conductance(3.0, 3.0, 1.0, 1.0, 1.99, false, 0.5);
        assert!((h - 2.0 * 3.0 * a).abs() < 1e-12);
        let (x, y) = (
            pair_conductance(1.0, 4.0, 1.0, 2.0, 2.9, false, 0.5),
            pair_conductance(4.0, 1.0, 2.0, 1.0, 2.9, false, 0.5),
        );
        assert_eq!(x, y);
        assert_eq!(pair_conductance(1.0, 1.0, 1.0, 1.0, 2.0001, false, 0.5), 0.0);
        // A bond conducts through its neck: 0.5 · min(r) = 0.5.
        assert!((pair_conductance(1.0, 1.0, 1.0, 1.0, 2.0001, true, 0.5) - 2.0 * 0.5).abs() < 1e-12);
    }
}
