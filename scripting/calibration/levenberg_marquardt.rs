//! Bounded non-linear least squares: minimise ½‖r(x)‖² by Levenberg–Marquardt with
//! Marquardt's scaling (the damping acts on diag(JᵀJ), so parameters of different units
//! are treated alike), a forward-difference Jacobian, and bounds kept by projecting each
//! trial point into the box. Residual functions may fail (a script closure, a run that
//! diverged); the error is passed on.

use super::{CalibrationError, Result};
use nalgebra::{DMatrix, DVector};

#[derive(Debug, Clone)]
pub struct Options {
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
    pub max_iterations: usize,
    /// Stop when the cost falls by less than this fraction in an accepted step.
    pub tolerance: f64,
}

impl Options {
    pub fn unbounded(n: usize) -> Self {
        Options {
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
            max_iterations: 200,
            tolerance: 1e-15,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    pub x: Vec<f64>,
    /// ½‖r‖² at x.
    pub cost: f64,
    pub residuals: Vec<f64>,
    pub iterations: usize,
    /// Whether a convergence test was met before the iteration limit.
    pub converged: bool,
}

/// Minimises ½‖r(x)‖² from `x0` within the bounds of `opts`.
pub fn minimise(mut residuals: impl FnMut(&[f64]) -> Result<Vec<f64>>, x0: &[f64], opts: &Options) -> Result<Solution> {
    let n = x0.len();
    if n == 0 || opts.lower.len() != n || opts.upper.len() != n {
        return Err(CalibrationError::new(format!(
            "{n} start value(s) with {} lower and {} upper bound(s): give one of each per parameter",
            opts.lower.len(),
            opts.upper.len()
        )));
    }
    if let Some(i) = (0..n).find(|&i| !(x0[i].is_finite() && opts.lower[i] <= opts.upper[i])) {
        return Err(CalibrationError::new(format!(
            "parameter {}: start {} with bounds [{}, {}]; the start must be finite and lower ≤ upper",
            i + 1,
            x0[i],
            opts.lower[i],
            opts.upper[i]
        )));
    }
    let project = |x: &mut [f64]| (0..n).for_each(|i| x[i] = x[i].clamp(opts.lower[i], opts.upper[i]));
    let mut eval = |x: &[f64]| -> Result<DVector<f64>> {
        let r = residuals(x)?;
        if let Some(k) = r.iter().position(|v| !v.is_finite()) {
            return Err(CalibrationError::new(format!("residual {} is {} at x = {x:?}", k + 1, r[k])));
        }
        Ok(DVector::from_vec(r))
    };
    let mut x = x0.to_vec();
    project(&mut x);
    let mut r = eval(&x)?;
    let mut cost = 0.5 * r.norm_squared();
    let mut lambda = 1e-3;
    let mut converged = false;
    let mut iterations = 0;
    while iterations < opts.max_iterations && !converged {
        iterations += 1;
        if cost == 0.0 {
            converged = true;
            break;
        }
        // Forward differences, stepping inwards at an upper bound.
        let mut jac = DMatrix::zeros(r.len(), n);
        for i in 0..n {
            let h = 1e-7 * x[i].abs().max(1e-3);
            let mut xh = x.clone();
            xh[i] = if x[i] + h > opts.upper[i] { x[i] - h } else { x[i] + h };
            let rh = eval(&xh)?;
            if rh.len() != r.len() {
                return Err(CalibrationError::new("the residual function returned a different number of residuals"));
            }
            jac.set_column(i, &((rh - &r) / (xh[i] - x[i])));
        }
        let jtj = jac.transpose() * &jac;
        let g = jac.transpose() * &r;
        if g.amax() <= 1e-14 * (1.0 + cost) {
            converged = true;
            break;
        }
        let mut accepted = false;
        for _ in 0..40 {
            let mut a = jtj.clone();
            for i in 0..n {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(step) = a.clone().cholesky().map(|c| c.solve(&(-&g))).or_else(|| a.lu().solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial: Vec<f64> = (0..n).map(|i| x[i] + step[i]).collect();
            project(&mut trial);
            let rt = eval(&trial)?;
            let ct = 0.5 * rt.norm_squared();
            if ct < cost {
                let moved = (0..n).map(|i| (trial[i] - x[i]).abs() / x[i].abs().max(1e-12)).fold(0.0, f64::max);
                let drop = (cost - ct) / cost;
                x = trial;
                r = rt;
                cost = ct;
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                converged = drop < opts.tolerance || moved < 1e-15 || cost == 0.0;
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            // No step lowers the cost: a (possibly bound-constrained) minimum.
            converged = true;
        }
    }
    Ok(Solution { x, cost, residuals: r.iter().copied().collect(), iterations, converged })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rosenbrock_valley_is_solved_to_its_minimum() {
        // r = (10(y − x²), 1 − x): minimum at (1, 1).
        let s = minimise(|p| Ok(vec![10.0 * (p[1] - p[0] * p[0]), 1.0 - p[0]]), &[-1.2, 1.0], &Options::unbounded(2))
            .unwrap();
        assert!((s.x[0] - 1.0).abs() < 1e-6 && (s.x[1] - 1.0).abs() < 1e-6, "{s:?}");
        assert!(s.converged);
    }

    #[test]
    fn a_decay_curve_recovers_its_known_parameters() {
        let (a, k, c) = (3.0, 0.7, 0.5);
        let t: Vec<f64> = (0..20).map(|i| i as f64 * 0.25).collect();
        let y: Vec<f64> = t.iter().map(|t| a * (-k * t).exp() + c).collect();
        let s = minimise(
            |p| Ok(t.iter().zip(&y).map(|(t, y)| p[0] * (-p[1] * t).exp() + p[2] - y).collect()),
            &[1.0, 0.1, 0.0],
            &Options::unbounded(3),
        )
        .unwrap();
        for (got, want) in s.x.iter().zip([a, k, c]) {
            assert!((got - want).abs() < 1e-7, "{:?}", s.x);
        }
    }

    #[test]
    fn bounds_hold_and_the_solution_sits_on_the_active_bound() {
        let mut opts = Options::unbounded(1);
        opts.lower = vec![2.0];
        opts.upper = vec![5.0];
        let s = minimise(|p| Ok(vec![p[0] - 1.0]), &[4.0], &opts).unwrap();
        assert_eq!(s.x, vec![2.0]);
    }

    #[test]
    fn a_failing_residual_function_and_bad_starts_are_reported() {
        let e = minimise(|_| Err(CalibrationError::new("run 3 diverged")), &[1.0], &Options::unbounded(1)).unwrap_err();
        assert_eq!(e.to_string(), "run 3 diverged");
        let e = minimise(|p| Ok(vec![p[0]]), &[f64::NAN], &Options::unbounded(1)).unwrap_err().to_string();
        assert!(e.contains("parameter 1") && e.contains("finite"), "{e}");
    }
}
