//! The part of a sphere below a water level, and the buoyant force on it.

/// Volume (m³) of a sphere of radius `r` centred at height `z` below the level `level`: the
/// whole sphere, none of it, or the spherical cap of height h = level − (z − r),
/// V = π·h²·(3r − h)/3.
#[inline]
pub fn submerged_volume(z: f64, r: f64, level: f64) -> f64 {
    // min/max, not `clamp`, which panics on a NaN or negative bound: a radius driven there
    // (a runaway temperature with thermal expansion, a forged lane) is the guard's to report.
    let h = (level - (z - r)).min(2.0 * r).max(0.0);
    std::f64::consts::PI * h * h * (3.0 * r - h) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cap_grows_from_nothing_to_the_whole_sphere() {
        let whole = 4.0 / 3.0 * std::f64::consts::PI;
        assert_eq!(submerged_volume(5.0, 1.0, 0.0), 0.0);
        assert!((submerged_volume(-5.0, 1.0, 0.0) - whole).abs() < 1e-12);
        assert!((submerged_volume(0.0, 1.0, 0.0) - 0.5 * whole).abs() < 1e-12);
        // h = 0.5: π·0.25·2.5/3.
        assert!((submerged_volume(0.5, 1.0, 0.0) - std::f64::consts::PI * 0.25 * 2.5 / 3.0).abs() < 1e-12);
    }
}
