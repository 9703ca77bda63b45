//! The multi-factor inversion of paper 002 §3.1: from target macro responses (τc, φ′, C)
//! back to the micro parameters that control them. Each response is fitted over the
//! design's runs by a quadratic surface without interactions,
//! y = b₀ + Σⱼ (bⱼ·zⱼ + cⱼ·zⱼ²), zⱼ = (xⱼ − midⱼ)/half-rangeⱼ,
//! which holds the linear, exponential, logarithmic and power trends of §2.2 to second
//! order over the tested range. The inversion solves for the free factors (the rest held
//! at given values, as the paper holds the insignificant ones at its reference run) by
//! Levenberg–Marquardt on the relative errors (ŷₖ − targetₖ)/targetₖ, within the design's
//! range, from several starts.

use super::levenberg_marquardt::{minimise, Options};
use super::{CalibrationError, Result};
use nalgebra::{DMatrix, DVector};

#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    pub factors: Vec<String>,
    pub responses: Vec<String>,
    /// Per factor: (low, high) of the data.
    pub range: Vec<(f64, f64)>,
    /// Per response: b₀, then (bⱼ, cⱼ) per factor.
    pub coefficients: Vec<Vec<f64>>,
    /// Per response, over the fitted runs.
    pub r2: Vec<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Inversion {
    /// Every factor's value: solved, or held.
    pub point: Vec<f64>,
    /// The surface's responses at `point` (for a refinement, the targets' responses with
    /// the confirmation runs' correction added).
    pub predicted: Vec<f64>,
    /// (predicted − target)/target per target, in the order given.
    pub relative_errors: Vec<f64>,
    pub converged: bool,
}

impl Surface {
    /// Fits one surface per response over `x[run][factor]`.
    pub fn fit(factors: &[String], x: &[Vec<f64>], responses: &[String], y: &[Vec<f64>]) -> Result<Surface> {
        let (n, m) = (x.len(), factors.len());
        let terms = 1 + 2 * m;
        if n < terms {
            return Err(CalibrationError::new(format!(
                "{n} run(s) for a surface of {terms} coefficients over {m} factor(s): give at least {terms} runs"
            )));
        }
        if x.iter().any(|r| r.len() != m) || y.len() != responses.len() || y.iter().any(|c| c.len() != n) {
            return Err(CalibrationError::new("every run needs a value of every factor and of every response"));
        }
        let range: Vec<(f64, f64)> = (0..m)
            .map(|j| x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| (lo.min(r[j]), hi.max(r[j]))))
            .collect();
        if let Some(j) = (0..m).find(|&j| range[j].1.partial_cmp(&range[j].0) != Some(std::cmp::Ordering::Greater)) {
            return Err(CalibrationError::new(format!("factor `{}` does not vary over the runs", factors[j])));
        }
        let mut a = DMatrix::zeros(n, terms);
        for (i, r) in x.iter().enumerate() {
            let row = basis(&range, r);
            for (k, v) in row.iter().enumerate() {
                a[(i, k)] = *v;
            }
        }
        let svd = a.clone().svd(true, true);
        let mut coefficients = Vec::new();
        let mut r2 = Vec::new();
        for (k, col) in y.iter().enumerate() {
            if let Some(i) = col.iter().position(|v| !v.is_finite()) {
                return Err(CalibrationError::new(format!(
                    "response `{}` of run {} is {}",
                    responses[k],
                    i + 1,
                    col[i]
                )));
            }
            let b = DVector::from_column_slice(col);
            let c = svd.solve(&b, 1e-12).map_err(|e| CalibrationError::new(format!("surface fit failed: {e}")))?;
            let fitted = &a * &c;
            let mean = col.iter().sum::<f64>() / n as f64;
            let tot: f64 = col.iter().map(|v| (v - mean).powi(2)).sum();
            let res = (&b - fitted).norm_squared();
            r2.push(if tot > 0.0 { 1.0 - res / tot } else { 1.0 });
            coefficients.push(c.iter().copied().collect());
        }
        Ok(Surface { factors: factors.to_vec(), responses: responses.to_vec(), range, coefficients, r2 })
    }

    /// Every response at a point (one value per factor).
    pub fn predict(&self, point: &[f64]) -> Vec<f64> {
        let row = basis(&self.range, point);
        self.coefficients.iter().map(|c| c.iter().zip(&row).map(|(a, b)| a * b).sum()).collect()
    }

    fn index(&self, kind: &str, names: &[String], name: &str) -> Result<usize> {
        names.iter().position(|n| n == name).ok_or_else(|| {
            CalibrationError::new(format!("unknown {kind} `{name}`; the surface has: {}", names.join(", ")))
        })
    }

    /// Solves for the factors not in `held` so the responses meet `targets`.
    pub fn invert(&self, targets: &[(String, f64)], held: &[(String, f64)]) -> Result<Inversion> {
        let problem = self.problem(targets, held)?;
        self.solve(&problem, |_| vec![0.0; problem.targets.len()])
    }

    /// Checks an inversion's targets and held factors: which responses are aimed at, which
    /// factors are free, and the point the held ones fix.
    pub(crate) fn problem(&self, targets: &[(String, f64)], held: &[(String, f64)]) -> Result<Problem> {
        let t: Vec<(usize, f64)> = targets
            .iter()
            .map(|(n, v)| Ok((self.index("response", &self.responses, n)?, *v)))
            .collect::<Result<_>>()?;
        if let Some((n, v)) = targets.iter().find(|(_, v)| !(v.is_finite() && *v != 0.0)) {
            return Err(CalibrationError::new(format!(
                "target `{n}` is {v}: targets must be finite and non-zero (errors are relative)"
            )));
        }
        let mut point: Vec<f64> = self.range.iter().map(|(lo, hi)| 0.5 * (lo + hi)).collect();
        let mut fixed = vec![false; self.factors.len()];
        for (n, v) in held {
            let j = self.index("factor", &self.factors, n)?;
            point[j] = *v;
            fixed[j] = true;
        }
        let free: Vec<usize> = (0..self.factors.len()).filter(|&j| !fixed[j]).collect();
        if free.is_empty() {
            return Err(CalibrationError::new("every factor is held: leave at least one free to solve for"));
        }
        if free.len() > t.len() {
            return Err(CalibrationError::new(format!(
                "{} free factor(s) ({}) for {} target(s): hold the others (e.g. at a reference run) so the inversion \
                 has a unique answer",
                free.len(),
                free.iter().map(|&j| self.factors[j].as_str()).collect::<Vec<_>>().join(", "),
                t.len()
            )));
        }
        Ok(Problem { targets: t, free, point })
    }

    /// Solves a checked problem on the surface plus `correction` (one value per target,
    /// added to the surface's prediction at a point of every factor): the free factors whose
    /// corrected responses meet the targets, within the design's range.
    pub(crate) fn solve(&self, problem: &Problem, correction: impl Fn(&[f64]) -> Vec<f64>) -> Result<Inversion> {
        let Problem { targets: t, free, point } = problem;
        let mut point = point.clone();
        let corrected = |p: &[f64]| -> Vec<f64> {
            let y = self.predict(p);
            let c = correction(p);
            t.iter().zip(&c).map(|(&(k, _), c)| y[k] + c).collect()
        };
        let opts = Options {
            lower: free.iter().map(|&j| self.range[j].0).collect(),
            upper: free.iter().map(|&j| self.range[j].1).collect(),
            max_iterations: 300,
            tolerance: 1e-16,
        };
        let residual = |z: &[f64]| -> Result<Vec<f64>> {
            let mut p = point.clone();
            free.iter().zip(z).for_each(|(&j, v)| p[j] = *v);
            Ok(corrected(&p).iter().zip(t).map(|(y, &(_, v))| (y - v) / v.abs()).collect())
        };
        // Starts at the centre and at the corners' midpoints towards each bound: the
        // surface may have more than one local minimum within the box.
        let mut starts = vec![free.iter().map(|&j| 0.5 * (self.range[j].0 + self.range[j].1)).collect::<Vec<_>>()];
        for s in [0.25, 0.75] {
            starts.push(free.iter().map(|&j| self.range[j].0 + s * (self.range[j].1 - self.range[j].0)).collect());
        }
        let mut best: Option<super::levenberg_marquardt::Solution> = None;
        for s in &starts {
            let sol = minimise(residual, s, &opts)?;
            if best.as_ref().is_none_or(|b| sol.cost < b.cost) {
                best = Some(sol);
            }
        }
        let best = best.expect("at least one start");
        free.iter().zip(&best.x).for_each(|(&j, v)| point[j] = *v);
        let mut predicted = self.predict(&point);
        for ((k, _), y) in t.iter().zip(corrected(&point)) {
            predicted[*k] = y;
        }
        let relative_errors = t.iter().map(|&(k, v)| (predicted[k] - v) / v.abs()).collect();
        Ok(Inversion { point, predicted, relative_errors, converged: best.converged })
    }

    /// The free factors of `point` scaled to [−1, 1] over the design's range.
    pub(crate) fn scaled(&self, free: &[usize], point: &[f64]) -> Vec<f64> {
        free.iter()
            .map(|&j| {
                let (lo, hi) = self.range[j];
                (point[j] - 0.5 * (lo + hi)) / (0.5 * (hi - lo))
            })
            .collect()
    }
}

/// An inversion's checked input: (response index, target) pairs, the free factors' indices
/// and a point of every factor (the held ones at their values).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Problem {
    pub targets: Vec<(usize, f64)>,
    pub free: Vec<usize>,
    pub point: Vec<f64>,
}

fn basis(range: &[(f64, f64)], x: &[f64]) -> Vec<f64> {
    let mut row = vec![1.0];
    for (j, (lo, hi)) in range.iter().enumerate() {
        let z = (x[j] - 0.5 * (lo + hi)) / (0.5 * (hi - lo));
        row.extend([z, z * z]);
    }
    row
}

#[cfg(test)]
mod tests {
    use super::super::orthogonal::OrthogonalArray;
    use super::*;

    /// A synthetic material: three responses of four factors, each a sum of one-factor
    /// quadratics (what the surface can hold exactly).
    fn model(p: &[f64]) -> Vec<f64> {
        let (lam, mu, sc, e) = (p[0], p[1], p[2], p[3]);
        vec![
            40.0 + 30.0 * lam + 8.0 * lam * lam + 20.0 * mu + 1e-5 * sc + 1e-10 * e,
            12.0 + 25.0 * mu - 6.0 * mu * mu + 0.5 * lam,
            -20.0 + 30.0 * lam + 2e-6 * sc - 1e-12 * sc * sc,
        ]
    }

    #[test]
    fn the_inversion_recovers_the_known_parameters_of_a_synthetic_model() {
        let levels = [
            vec![0.5, 0.75, 1.0, 1.25, 1.5],
            vec![0.2, 0.4, 0.6, 0.8, 1.0],
            vec![2e5, 4e5, 6e5, 8e5, 1e6],
            vec![1e8, 2e8, 3e8, 4e8, 5e8],
        ];
        let oa = OrthogonalArray::with_runs(25, 5).unwrap();
        let x: Vec<Vec<f64>> = oa.rows.iter().map(|r| (0..4).map(|j| levels[j][r[j] as usize]).collect()).collect();
        let ys: Vec<Vec<f64>> = x.iter().map(|p| model(p)).collect();
        let y: Vec<Vec<f64>> = (0..3).map(|k| ys.iter().map(|r| r[k]).collect()).collect();
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let s = Surface::fit(&names(&["lambda", "mu", "sigma_c", "E"]), &x, &names(&["tau", "phi", "C"]), &y).unwrap();
        assert!(s.r2.iter().all(|r| (r - 1.0).abs() < 1e-12), "{:?}", s.r2);
        let truth = [1.1, 0.55, 7.3e5, 3e8];
        let want = model(&truth);
        let targets: Vec<(String, f64)> =
            ["tau", "phi", "C"].iter().zip(&want).map(|(n, v)| (n.to_string(), *v)).collect();
        let inv = s.invert(&targets, &[("E".to_string(), 3e8)]).unwrap();
        for (got, want) in inv.point.iter().zip(truth) {
            assert!((got - want).abs() < 1e-6 * want, "{:?} vs {truth:?}", inv.point);
        }
        assert!(inv.relative_errors.iter().all(|e| e.abs() < 1e-9) && inv.converged);
    }

    #[test]
    fn an_underdetermined_inversion_is_refused_naming_the_free_factors() {
        let x: Vec<Vec<f64>> = (0..9).map(|i| vec![i as f64, (i * 7 % 9) as f64]).collect();
        let y = vec![x.iter().map(|r| r[0] + r[1]).collect()];
        let s = Surface::fit(&["a".into(), "b".into()], &x, &["y".into()], &y).unwrap();
        let e = s.invert(&[("y".into(), 3.0)], &[]).unwrap_err().to_string();
        assert!(e.contains("2 free factor(s) (a, b) for 1 target"), "{e}");
        assert!(s.invert(&[("z".into(), 3.0)], &[]).unwrap_err().to_string().contains("unknown response `z`"));
    }
}
