//! Normal dashpots set from a coefficient of restitution e.
//!
//! Linear spring–dashpot: e = exp(−ζπ/√(1−ζ²)), inverted exactly.
//! Hertz with the dashpot c = α·√(m*·Kh)·δ^(1/4) (Tsuji et al. 1992): in units where
//! m* = Kh = v0 = 1 the impact obeys x'' = −x^(3/2) − α·x^(1/4)·x', whatever the speed, so
//! e depends on α alone. We integrate that equation once per requested e and invert by
//! bisection, which makes the simulated restitution equal the requested one.

use std::sync::{Mutex, OnceLock};

/// Damping ratio ζ of a linear spring–dashpot with restitution `e` (0 → critical).
pub fn linear_damping_ratio(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    if e <= 0.0 {
        return 1.0;
    }
    let l = e.ln();
    -l / (std::f64::consts::PI.powi(2) + l * l).sqrt()
}

/// Restitution of a dimensionless Hertz impact with dashpot coefficient α (0 if it never
/// separates within a long window).
pub fn hertz_restitution(alpha: f64) -> f64 {
    // RK4 on (x, v); the undamped contact lasts t ≈ 3.22 in these units.
    let h = 2e-4;
    let accel = |x: f64, v: f64| {
        let xp = x.max(0.0);
        -(xp * xp.sqrt()) - alpha * xp.sqrt().sqrt() * v
    };
    let (mut x, mut v) = (0.0f64, 1.0f64);
    let mut t = 0.0;
    while t < 60.0 {
        let (k1x, k1v) = (v, accel(x, v));
        let (k2x, k2v) = (v + 0.5 * h * k1v, accel(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
        let (k3x, k3v) = (v + 0.5 * h * k2v, accel(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
        let (k4x, k4v) = (v + h * k3v, accel(x + h * k3x, v + h * k3v));
        let xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        if xn <= 0.0 && t > 0.0 {
            // Exit speed, interpolated to the crossing.
            let f = x / (x - xn);
            return -(v + f * (vn - v));
        }
        x = xn;
        v = vn;
        t += h;
    }
    0.0
}

/// The Hertz dashpot coefficient α that gives restitution `e` (memoised).
pub fn hertz_damping_alpha(e: f64) -> f64 {
    if e >= 1.0 {
        return 0.0;
    }
    static CACHE: OnceLock<Mutex<Vec<(u64, f64)>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
    let key = e.to_bits();
    if let Some(&(_, a)) = cache.lock().unwrap_or_else(|p| p.into_inner()).iter().find(|(k, _)| *k == key) {
        return a;
    }
    let (mut lo, mut hi) = (0.0f64, 8.0f64);
    while hertz_restitution(hi) > e.max(0.0) && hi < 1e3 {
        hi *= 2.0;
    }
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if hertz_restitution(mid) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // For e = 0 take the upper end: the smallest α that never rebounds.
    let a = if e <= 0.0 { hi } else { 0.5 * (lo + hi) };
    cache.lock().unwrap_or_else(|p| p.into_inner()).push((key, a));
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_damping_ratio_matches_restitution_table() {
        // physics.md §2.
        assert!((linear_damping_ratio(0.7) - 0.112808).abs() < 1e-6);
        assert!((linear_damping_ratio(0.3) - 0.357857).abs() < 1e-6);
        assert_eq!(linear_damping_ratio(1.0), 0.0);
        assert_eq!(linear_damping_ratio(0.0), 1.0);
    }

    #[test]
    fn undamped_hertz_restitution_is_one() {
        assert!((hertz_restitution(0.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn hertz_alpha_inverts_restitution() {
        for e in [0.1, 0.3, 0.5, 0.9] {
            let a = hertz_damping_alpha(e);
            assert!((hertz_restitution(a) - e).abs() < 1e-6, "e = {e}");
        }
        assert_eq!(hertz_restitution(hertz_damping_alpha(0.0)), 0.0);
    }
}
