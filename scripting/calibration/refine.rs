//! Iterating an inversion with confirmation runs: after a run at the inverted point, its
//! measured responses correct the response surface and the inversion is solved again, until
//! every target is met or the rounds run out — the loop a calibration needs when the surface
//! fitted over the design is not accurate enough near the targets (paper 002's
//! "fine-tuning", done systematically).
//!
//! The method is output space mapping with a Broyden-updated linear correction (Bandler et
//! al., "Space mapping: the state of the art", IEEE Trans. MTT 52(1), 2004, §V; Koziel,
//! Bandler & Madsen 2006). The surface S stays as fitted; after confirmation k at x_k with
//! measured responses y_k, the model inverted next is
//!
//!   M_k(x) = S(x) + d_k + L_k·(z(x) − z_k),   d_k = y_k − S(x_k),
//!
//! z the free factors scaled to [−1, 1] over the design. M_k meets every run exactly at
//! x_k (the zero-order term, the earlier "shift the surface by the miss"); L starts at 0 and
//! takes Broyden's rank-one update from each pair of consecutive runs so that M_k also
//! meets y_{k−1} at x_{k−1}:
//!
//!   L_k = L_{k−1} + (Δd − L_{k−1}·Δz)·Δzᵀ / (Δzᵀ·Δz),   Δd = d_k − d_{k−1}, Δz = z_k − z_{k−1}.
//!
//! Solving M_k(x) = target is then a quasi-Newton step on the true response F = S + misfit,
//! with the surface's own Jacobian plus the secant estimate of the misfit's; for a smooth
//! misfit and a start close enough it converges superlinearly, as Broyden's method does.
//! Added runs are not refitted into the surface: 25 design runs outweigh a few confirmations
//! in a least-squares fit, which therefore barely moves where it is wrong.

use super::response_surface::{Inversion, Problem, Surface};
use super::{CalibrationError, Result};

/// One confirmation run: where it ran and what the inversion expected and the run gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Round {
    /// Every factor's value.
    pub point: Vec<f64>,
    /// The corrected model's responses at `point` when it was proposed, one per target.
    pub predicted: Vec<f64>,
    /// The run's responses, one per target.
    pub measured: Vec<f64>,
    /// (measured − target)/|target| per target.
    pub relative_errors: Vec<f64>,
}

/// An inversion being refined by confirmation runs: [`Refinement::propose`] the next point,
/// run it, [`Refinement::confirm`] what it gave; repeat until [`Refinement::within`].
#[derive(Debug, Clone)]
pub struct Refinement {
    surface: Surface,
    problem: Problem,
    /// The targets' names, in the order of `problem.targets`.
    pub target_names: Vec<String>,
    /// Confirmation runs so far, in order.
    pub rounds: Vec<Round>,
    /// The linear correction L (targets × free factors, in scaled units).
    slope: Vec<Vec<f64>>,
    /// The last proposal's corrected prediction, one per target (kept for its round).
    proposed: Option<(Vec<f64>, Vec<f64>)>,
}

impl Refinement {
    /// Starts a refinement of the inversion `surface.invert(targets, held)`.
    pub fn new(surface: &Surface, targets: &[(String, f64)], held: &[(String, f64)]) -> Result<Refinement> {
        let problem = surface.problem(targets, held)?;
        let slope = vec![vec![0.0; problem.free.len()]; problem.targets.len()];
        Ok(Refinement {
            surface: surface.clone(),
            target_names: targets.iter().map(|(n, _)| n.clone()).collect(),
            problem,
            rounds: Vec::new(),
            slope,
            proposed: None,
        })
    }

    /// The surface being corrected.
    pub fn surface(&self) -> &Surface {
        &self.surface
    }

    /// The free factors' indices in the surface's factors.
    pub fn free(&self) -> &[usize] {
        &self.problem.free
    }

    /// The correction to add to the surface's prediction of each target at `point`.
    fn correction(&self, point: &[f64]) -> Vec<f64> {
        let Some(last) = self.rounds.last() else {
            return vec![0.0; self.problem.targets.len()];
        };
        let s = self.surface.predict(&last.point);
        let z = self.surface.scaled(&self.problem.free, point);
        let zk = self.surface.scaled(&self.problem.free, &last.point);
        self.problem
            .targets
            .iter()
            .enumerate()
            .map(|(i, &(k, _))| {
                let offset = last.measured[i] - s[k];
                offset + self.slope[i].iter().zip(z.iter().zip(&zk)).map(|(l, (a, b))| l * (a - b)).sum::<f64>()
            })
            .collect()
    }

    /// The next point to run: the inversion of the surface corrected by the runs so far (the
    /// plain inversion before any run).
    pub fn propose(&mut self) -> Result<Inversion> {
        let inv = self.surface.solve(&self.problem, |p| self.correction(p))?;
        let predicted = self.problem.targets.iter().map(|&(k, _)| inv.predicted[k]).collect();
        self.proposed = Some((inv.point.clone(), predicted));
        Ok(inv)
    }

    /// Records a confirmation run at `point` (every factor's value) with its `measured`
    /// responses (one per target, in the targets' order) and updates the correction.
    /// Returns the run's relative errors against the targets.
    pub fn confirm(&mut self, point: &[f64], measured: &[f64]) -> Result<Vec<f64>> {
        let m = self.surface.factors.len();
        if point.len() != m {
            return Err(CalibrationError::new(format!(
                "the point has {} value(s); the surface has {m} factor(s) ({})",
                point.len(),
                self.surface.factors.join(", ")
            )));
        }
        if measured.len() != self.problem.targets.len() {
            return Err(CalibrationError::new(format!(
                "{} measured value(s) for {} target(s) ({})",
                measured.len(),
                self.problem.targets.len(),
                self.target_names.join(", ")
            )));
        }
        if let Some(i) = (0..m).find(|&i| !point[i].is_finite()) {
            return Err(CalibrationError::new(format!("factor `{}` is {}", self.surface.factors[i], point[i])));
        }
        if let Some(i) = measured.iter().position(|v| !v.is_finite()) {
            return Err(CalibrationError::new(format!(
                "the measured `{}` is {}: a run that failed cannot correct the surface",
                self.target_names[i], measured[i]
            )));
        }
        let predicted = match &self.proposed {
            Some((p, y)) if p.as_slice() == point => y.clone(),
            _ => {
                let s = self.surface.predict(point);
                let c = self.correction(point);
                self.problem.targets.iter().zip(c).map(|(&(k, _), c)| s[k] + c).collect()
            }
        };
        if let Some(last) = self.rounds.last() {
            // Broyden's update of L from this run and the last (misfits d = y − S).
            let free = &self.problem.free;
            let dz: Vec<f64> = self
                .surface
                .scaled(free, point)
                .iter()
                .zip(self.surface.scaled(free, &last.point))
                .map(|(a, b)| a - b)
                .collect();
            let dz2: f64 = dz.iter().map(|v| v * v).sum();
            // NOTE: two runs at the same point (within 1e-9 of the range) say nothing about
            // the slope; the offset alone is updated.
            if dz2 > 1e-18 {
                let (s_new, s_old) = (self.surface.predict(point), self.surface.predict(&last.point));
                for (i, &(k, _)) in self.problem.targets.iter().enumerate() {
                    let dd = (measured[i] - s_new[k]) - (last.measured[i] - s_old[k]);
                    let ldz: f64 = self.slope[i].iter().zip(&dz).map(|(l, d)| l * d).sum();
                    for (l, d) in self.slope[i].iter_mut().zip(&dz) {
                        *l += (dd - ldz) * d / dz2;
                    }
                }
            }
        }
        let relative_errors: Vec<f64> =
            measured.iter().zip(&self.problem.targets).map(|(y, &(_, t))| (y - t) / t.abs()).collect();
        self.rounds.push(Round {
            point: point.to_vec(),
            predicted,
            measured: measured.to_vec(),
            relative_errors: relative_errors.clone(),
        });
        self.proposed = None;
        Ok(relative_errors)
    }

    /// Whether the last run met every target within `tolerance` (relative; 0.1 = 10 %).
    pub fn within(&self, tolerance: f64) -> bool {
        self.rounds.last().is_some_and(|r| r.relative_errors.iter().all(|e| e.abs() <= tolerance))
    }

    /// Runs the loop on a model of the runs: propose, run `f`, confirm, until every target
    /// is within `tolerance` or `max_rounds` runs were made. Returns whether it was met.
    pub fn iterate(
        &mut self,
        mut f: impl FnMut(&[f64]) -> Result<Vec<f64>>,
        tolerance: f64,
        max_rounds: usize,
    ) -> Result<bool> {
        while self.rounds.len() < max_rounds {
            let inv = self.propose()?;
            let y = f(&inv.point)?;
            self.confirm(&inv.point, &y)?;
            if self.within(tolerance) {
                return Ok(true);
            }
        }
        Ok(self.within(tolerance))
    }
}

#[cfg(test)]
mod tests {
    use super::super::orthogonal::OrthogonalArray;
    use super::*;

    const NAMES: [&str; 4] = ["lambda", "mu", "sigma_c", "E"];
    const RESPONSES: [&str; 3] = ["tau", "c", "phi"];

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// A surface fitted over an L25 of `model` (four factors at five levels).
    fn fitted(model: impl Fn(&[f64]) -> Vec<f64>) -> Surface {
        let levels = [
            vec![0.3, 0.4, 0.5, 0.6, 0.7],
            vec![0.1, 0.3, 0.5, 0.7, 0.9],
            vec![1e5, 2e5, 3e5, 4e5, 5e5],
            vec![5e7, 1e8, 1.5e8, 2e8, 2.5e8],
        ];
        let oa = OrthogonalArray::with_runs(25, 5).unwrap();
        let x: Vec<Vec<f64>> = oa.rows.iter().map(|r| (0..4).map(|j| levels[j][r[j] as usize]).collect()).collect();
        let ys: Vec<Vec<f64>> = x.iter().map(|p| model(p)).collect();
        let y: Vec<Vec<f64>> = (0..3).map(|k| ys.iter().map(|r| r[k]).collect()).collect();
        Surface::fit(&names(&NAMES), &x, &names(&RESPONSES), &y).unwrap()
    }

    /// A material the quadratic surface cannot hold: exponentials, logarithms and products
    /// of factors (the surface has no interaction terms). τc-, C- and φ′-like magnitudes.
    fn nonlinear(p: &[f64]) -> Vec<f64> {
        let (lam, mu, sc, e) = (p[0], p[1], p[2] / 1e5, p[3] / 1e8);
        vec![
            40.0 * (1.2 * lam).exp() * (0.3 + mu).sqrt() + 6.0 * sc * lam + 5.0 * e * mu,
            4.0 + 60.0 * lam * mu + 3.0 * sc * (1.0 + mu) + 2.0 * lam * sc * sc,
            18.0 + 12.0 * (1.0 + 3.0 * mu).ln() + 10.0 * lam * lam * (1.0 + mu) + 0.5 * e,
        ]
    }

    fn targets_at(model: impl Fn(&[f64]) -> Vec<f64>, truth: &[f64]) -> Vec<(String, f64)> {
        RESPONSES.iter().zip(model(truth)).map(|(n, v)| (n.to_string(), v)).collect()
    }

    #[test]
    fn a_constant_misfit_is_corrected_by_the_first_confirmation_run() {
        // The runs differ from a surface that holds the design exactly by a constant: one run
        // measures it and the next proposal meets the targets exactly.
        let quadratic = |p: &[f64]| {
            let (lam, mu, sc) = (p[0], p[1], p[2] / 1e5);
            vec![
                50.0 + 80.0 * lam * lam + 30.0 * mu + sc,
                10.0 + 20.0 * mu - 5.0 * mu * mu + 4.0 * sc,
                20.0 + 10.0 * lam + 8.0 * mu,
            ]
        };
        let s = fitted(quadratic);
        let runs = |p: &[f64]| -> Vec<f64> { quadratic(p).iter().zip([7.0, -3.0, 1.5]).map(|(y, d)| y + d).collect() };
        let truth = [0.52, 0.44, 3.1e5, 1.5e8];
        let mut r = Refinement::new(&s, &targets_at(runs, &truth), &[("E".into(), 1.5e8)]).unwrap();
        let first = r.propose().unwrap();
        let e1 = r.confirm(&first.point, &runs(&first.point)).unwrap();
        assert!(e1.iter().any(|e| e.abs() > 0.02), "the plain inversion already meets the targets: {e1:?}");
        let second = r.propose().unwrap();
        let e2 = r.confirm(&second.point, &runs(&second.point)).unwrap();
        assert!(e2.iter().all(|e| e.abs() < 1e-9), "{e2:?}");
        for (got, want) in second.point.iter().zip(truth) {
            assert!((got - want).abs() < 1e-6 * want, "{:?} vs {truth:?}", second.point);
        }
    }

    #[test]
    fn the_iteration_converges_where_the_surface_misfits_a_nonlinear_material() {
        let s = fitted(nonlinear);
        assert!(s.r2.iter().all(|r| *r < 0.9999), "the surface holds the model: nothing to refine ({:?})", s.r2);
        let truth = [0.55, 0.35, 2.2e5, 1.5e8];
        let targets = targets_at(nonlinear, &truth);
        let mut r = Refinement::new(&s, &targets, &[("E".into(), 1.5e8)]).unwrap();
        let met = r.iterate(|p| Ok(nonlinear(p)), 1e-8, 8).unwrap();
        let worst: Vec<f64> =
            r.rounds.iter().map(|k| k.relative_errors.iter().fold(0.0_f64, |a, e| a.max(e.abs()))).collect();
        crate::eoutln!("largest relative error by round: {worst:?}");
        // The plain inversion (round 1) misses by several per cent: the test has work to do.
        assert!(worst[0] > 0.03, "{worst:?}");
        assert!(met, "not within 1e-8 in 8 rounds: {worst:?}");
        // Within 10 % by the second run (the goal of paper 002) and converging: each round at
        // least 3 times closer than the one before (measured: 8 %, 2.4 %, 0.16 %, 4.5e-5,
        // 4.8e-6, 4.0e-7, 4.2e-10).
        assert!(worst[1] < 0.10, "{worst:?}");
        for k in 1..worst.len() {
            assert!(worst[k] < worst[k - 1] / 3.0, "round {}: {worst:?}", k + 1);
        }
        let last = &r.rounds.last().unwrap().point;
        for (got, want) in last.iter().zip(truth) {
            assert!((got - want).abs() < 1e-6 * want, "{last:?} vs {truth:?}");
        }
    }

    #[test]
    fn the_broyden_slope_beats_the_offset_alone() {
        // The same loop with the slope left at zero (only the surface shifted by the last
        // miss, as the example did before: a chord method, linear convergence) is slower.
        // Measured after five runs: 4.8e-6 against 4.0e-5.
        let s = fitted(nonlinear);
        let truth = [0.55, 0.35, 2.2e5, 1.5e8];
        let targets = targets_at(nonlinear, &truth);
        let held = [("E".to_string(), 1.5e8)];
        let mut broyden = Refinement::new(&s, &targets, &held).unwrap();
        let mut offset = Refinement::new(&s, &targets, &held).unwrap();
        for _ in 0..5 {
            broyden.iterate(|p| Ok(nonlinear(p)), 0.0, broyden.rounds.len() + 1).unwrap();
            let inv = offset.propose().unwrap();
            offset.confirm(&inv.point, &nonlinear(&inv.point)).unwrap();
            offset.slope.iter_mut().for_each(|row| row.iter_mut().for_each(|l| *l = 0.0));
        }
        let worst =
            |r: &Refinement| r.rounds.last().unwrap().relative_errors.iter().fold(0.0_f64, |a, e| a.max(e.abs()));
        assert!(worst(&broyden) < 0.2 * worst(&offset), "{} vs {}", worst(&broyden), worst(&offset));
    }

    #[test]
    fn bad_confirmations_are_refused_with_what_to_give() {
        let s = fitted(nonlinear);
        let targets = targets_at(nonlinear, &[0.5, 0.5, 3e5, 1.5e8]);
        let mut r = Refinement::new(&s, &targets, &[("E".into(), 1.5e8)]).unwrap();
        let e = r.confirm(&[0.5, 0.5], &[1.0, 2.0, 3.0]).unwrap_err().to_string();
        assert!(e.contains("2 value(s)") && e.contains("4 factor(s)"), "{e}");
        let e = r.confirm(&[0.5, 0.5, 3e5, 1.5e8], &[1.0, 2.0]).unwrap_err().to_string();
        assert!(e.contains("2 measured value(s) for 3 target(s) (tau, c, phi)"), "{e}");
        let e = r.confirm(&[0.5, 0.5, 3e5, 1.5e8], &[1.0, f64::NAN, 3.0]).unwrap_err().to_string();
        assert!(e.contains("`c` is NaN"), "{e}");
        assert!(r.rounds.is_empty() && !r.within(1.0));
    }
}
