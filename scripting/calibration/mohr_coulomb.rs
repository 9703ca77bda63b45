//! The Mohr–Coulomb envelope τ = C + σ·tan φ′ fitted by least squares to peak (or residual)
//! shear strengths measured at several normal stresses (paper 002 §1: C and φ′ of each
//! direct shear series).

use super::{CalibrationError, Result};

#[derive(Debug, Clone, PartialEq)]
pub struct Envelope {
    /// Cohesion C, in the unit of τ.
    pub cohesion: f64,
    /// Friction angle φ′, degrees.
    pub phi_deg: f64,
    /// R² of the line (1 for two points).
    pub r2: f64,
}

pub fn fit(sigma: &[f64], tau: &[f64]) -> Result<Envelope> {
    if sigma.len() != tau.len() || sigma.len() < 2 {
        return Err(CalibrationError::new(format!(
            "{} normal stress(es) and {} strength(s): give one strength per normal stress, at least two",
            sigma.len(),
            tau.len()
        )));
    }
    if let Some(i) = (0..sigma.len()).find(|&i| !(sigma[i].is_finite() && tau[i].is_finite())) {
        return Err(CalibrationError::new(format!(
            "point {} is (σ {}, τ {}): every point must be finite",
            i + 1,
            sigma[i],
            tau[i]
        )));
    }
    let n = sigma.len() as f64;
    let (ms, mt) = (sigma.iter().sum::<f64>() / n, tau.iter().sum::<f64>() / n);
    let sxx: f64 = sigma.iter().map(|s| (s - ms).powi(2)).sum();
    if sxx <= 0.0 {
        return Err(CalibrationError::new("the normal stresses are all equal: shear at two or more different ones"));
    }
    let slope = sigma.iter().zip(tau).map(|(s, t)| (s - ms) * (t - mt)).sum::<f64>() / sxx;
    let cohesion = mt - slope * ms;
    let ss_tot: f64 = tau.iter().map(|t| (t - mt).powi(2)).sum();
    let ss_res: f64 = sigma.iter().zip(tau).map(|(s, t)| (t - cohesion - slope * s).powi(2)).sum();
    let r2 = if ss_tot > 0.0 { 1.0 - ss_res / ss_tot } else { 1.0 };
    Ok(Envelope { cohesion, phi_deg: slope.atan().to_degrees(), r2 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_known_envelope_is_recovered() {
        let sigma = [50e3, 100e3, 200e3, 300e3];
        let tau: Vec<f64> = sigma.iter().map(|s| 15e3 + s * 30f64.to_radians().tan()).collect();
        let e = fit(&sigma, &tau).unwrap();
        assert!((e.cohesion - 15e3).abs() < 1e-6 && (e.phi_deg - 30.0).abs() < 1e-10 && (e.r2 - 1.0).abs() < 1e-12);
        assert!(fit(&[1.0, 1.0], &[2.0, 3.0]).unwrap_err().to_string().contains("all equal"));
        assert!(fit(&[1.0], &[2.0]).unwrap_err().to_string().contains("at least two"));
    }
}
