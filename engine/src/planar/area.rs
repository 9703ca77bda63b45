//! The area a disc shares with an axis-aligned rectangle, exactly: what a 2D model's porosity
//! counts (a sphere of the layer is a disc of the x–z plane).

/// ∫ √(r² − x²) dx from 0 to `x` (|x| ≤ r).
fn half_chord_integral(x: f64, r: f64) -> f64 {
    let x = x.clamp(-r, r);
    0.5 * (x * (r * r - x * x).max(0.0).sqrt() + r * r * (x / r).clamp(-1.0, 1.0).asin())
}

/// The area of {X ≤ x, Z ≤ z} inside the disc of radius `r` centred at the origin.
fn quadrant_area(x: f64, z: f64, r: f64) -> f64 {
    let x = x.clamp(-r, r);
    if z >= r {
        // The whole chord below z: 2·∫ s(X) dX from −r to x.
        return 2.0 * (half_chord_integral(x, r) - half_chord_integral(-r, r));
    }
    if z <= -r {
        return 0.0;
    }
    // Where the chord crosses z (|X| < w), the strip below z is z + s(X); outside it the whole
    // chord lies below z (z ≥ 0) or above it (z < 0).
    let w = (r * r - z * z).sqrt();
    let mut area = 0.0;
    let lo = -r;
    let a = x.min(-w);
    if z >= 0.0 && a > lo {
        area += 2.0 * (half_chord_integral(a, r) - half_chord_integral(lo, r));
    }
    let (b0, b1) = (-w, x.min(w));
    if b1 > b0 {
        area += z * (b1 - b0) + half_chord_integral(b1, r) - half_chord_integral(b0, r);
    }
    if z >= 0.0 && x > w {
        area += 2.0 * (half_chord_integral(x, r) - half_chord_integral(w, r));
    }
    area
}

/// The area the disc of radius `r` centred at (`cx`, `cz`) shares with the rectangle
/// [x0, x1] × [z0, z1] (m²).
pub fn disc_rectangle_area(cx: f64, cz: f64, r: f64, (x0, x1): (f64, f64), (z0, z1): (f64, f64)) -> f64 {
    if x1 <= x0 || z1 <= z0 || r <= 0.0 {
        return 0.0;
    }
    let q = |x: f64, z: f64| quadrant_area(x - cx, z - cz, r);
    (q(x1, z1) - q(x0, z1) - q(x1, z0) + q(x0, z0)).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn a_disc_inside_counts_whole_and_a_halved_or_quartered_one_by_its_part() {
        let r = 0.3;
        let whole = PI * r * r;
        let a = disc_rectangle_area(0.0, 0.0, r, (-1.0, 1.0), (-1.0, 1.0));
        assert!((a - whole).abs() < 1e-15, "{a}");
        let half = disc_rectangle_area(0.0, 0.0, r, (0.0, 1.0), (-1.0, 1.0));
        assert!((half - whole / 2.0).abs() < 1e-15, "{half}");
        let below = disc_rectangle_area(0.0, 0.0, r, (-1.0, 1.0), (-1.0, 0.0));
        assert!((below - whole / 2.0).abs() < 1e-15, "{below}");
        let quarter = disc_rectangle_area(0.0, 0.0, r, (0.0, 1.0), (0.0, 1.0));
        assert!((quarter - whole / 4.0).abs() < 1e-15, "{quarter}");
        assert_eq!(disc_rectangle_area(5.0, 0.0, r, (-1.0, 1.0), (-1.0, 1.0)), 0.0);
    }

    /// A circular segment: the disc cut by z ≤ h has area r²·acos(−h/r) + h·√(r² − h²).
    #[test]
    fn a_disc_cut_by_a_line_has_the_segment_area() {
        let r: f64 = 1.0;
        for h in [-0.9f64, -0.4, 0.0, 0.25, 0.7] {
            let exact = r * r * (-h / r).acos() + h * (r * r - h * h).sqrt();
            let a = disc_rectangle_area(0.0, 0.0, r, (-2.0, 2.0), (-2.0, h));
            assert!((a - exact).abs() < 1e-14, "h {h}: {a} against {exact}");
            let side = disc_rectangle_area(0.0, 0.0, r, (-2.0, h), (-2.0, 2.0));
            assert!((side - exact).abs() < 1e-14, "h {h}: {side} against {exact}");
        }
    }

    /// A corner cut off the disc, against a fine midpoint sum over x of the clipped chord.
    #[test]
    fn a_corner_of_a_disc_matches_a_fine_quadrature() {
        let (cx, cz, r) = (0.1, -0.2, 0.5);
        let (x0, x1, z0, z1) = (-0.05, 0.9, -0.45, 0.12);
        let n = 200_000;
        let mut sum = 0.0;
        for k in 0..n {
            let x = cx - r + 2.0 * r * (k as f64 + 0.5) / n as f64;
            if x < x0 || x > x1 {
                continue;
            }
            let s = (r * r - (x - cx).powi(2)).max(0.0).sqrt();
            let (lo, hi) = ((cz - s).max(z0), (cz + s).min(z1));
            sum += (hi - lo).max(0.0) * 2.0 * r / n as f64;
        }
        let a = disc_rectangle_area(cx, cz, r, (x0, x1), (z0, z1));
        assert!((a - sum).abs() < 1e-8, "{a} against {sum}");
    }
}
