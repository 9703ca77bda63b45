//! Fits the material tests need: a least-squares line, and the Mohr–Coulomb envelope of
//! peak strengths (σ1 = a + N·σ3 with N = (1 + sin φ)/(1 − sin φ)).

/// Least-squares line `y = a + b·x`; `None` with fewer than two distinct `x`.
pub fn line_fit(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let n = x.len().min(y.len());
    if n < 2 {
        return None;
    }
    let mx = x[..n].iter().sum::<f64>() / n as f64;
    let my = y[..n].iter().sum::<f64>() / n as f64;
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for k in 0..n {
        sxx += (x[k] - mx) * (x[k] - mx);
        sxy += (x[k] - mx) * (y[k] - my);
    }
    if sxx <= 0.0 || !sxx.is_finite() {
        return None;
    }
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

/// A Mohr–Coulomb envelope in principal stresses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MohrCoulomb {
    /// Slope N of σ1 against σ3 (the passive coefficient (1 + sin φ)/(1 − sin φ)).
    pub slope: f64,
    /// Intercept: the unconfined strength of the envelope (Pa).
    pub intercept: f64,
    /// Internal friction μi = tan φ = (N − 1)/(2√N).
    pub internal_friction: f64,
    /// Cohesion c = intercept/(2√N) (Pa).
    pub cohesion: f64,
}

/// Fits σ1 = a + N·σ3 to `(σ3, σ1)` peak pairs. `None` with fewer than two confining
/// stresses, or an envelope that falls with confinement (N ≤ 0: no friction angle).
pub fn mohr_coulomb(points: &[(f64, f64)]) -> Option<MohrCoulomb> {
    let (s3, s1): (Vec<f64>, Vec<f64>) = points.iter().copied().unzip();
    let (a, n) = line_fit(&s3, &s1)?;
    if n <= 0.0 {
        return None;
    }
    // N = (√(1 + μ²) + μ)², so √N = sec φ + tan φ and tan φ = (N − 1)/(2√N).
    Some(MohrCoulomb {
        slope: n,
        intercept: a,
        internal_friction: (n - 1.0) / (2.0 * n.sqrt()),
        cohesion: a / (2.0 * n.sqrt()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_recovers_an_exact_line_and_refuses_one_point() {
        let x = [0.0, 1.0, 2.0, 5.0];
        let y: Vec<f64> = x.iter().map(|v| 3.0 - 2.5 * v).collect();
        let (a, b) = line_fit(&x, &y).unwrap();
        assert!((a - 3.0).abs() < 1e-12 && (b + 2.5).abs() < 1e-12);
        assert!(line_fit(&[1.0], &[2.0]).is_none());
        assert!(line_fit(&[1.0, 1.0], &[2.0, 3.0]).is_none());
    }

    #[test]
    fn mohr_coulomb_recovers_friction_and_cohesion_of_a_known_envelope() {
        // φ from μi = 1 (45°): N = (√2 + 1)², c = 20 MPa → unconfined 2c√N.
        for mu in [0.354f64, 0.6, 1.0] {
            let n = ((1.0 + mu * mu).sqrt() + mu).powi(2);
            let c = 20e6;
            let pts: Vec<(f64, f64)> = [0.0, 10e6, 30e6].iter().map(|&s3| (s3, 2.0 * c * n.sqrt() + n * s3)).collect();
            let mc = mohr_coulomb(&pts).unwrap();
            assert!((mc.internal_friction - mu).abs() < 1e-12, "{mc:?}");
            assert!((mc.cohesion - c).abs() < 1e-6 * c);
            // tan φ from the slope agrees with φ = asin((N − 1)/(N + 1)).
            let phi = ((n - 1.0) / (n + 1.0)).asin();
            assert!((phi.tan() - mu).abs() < 1e-12);
        }
        assert!(mohr_coulomb(&[(0.0, 5.0), (1.0, 4.0)]).is_none());
    }
}
