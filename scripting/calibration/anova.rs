//! Main-effect analysis of variance over an orthogonal design (paper 002 §2.1, what SPSS's
//! multi-factor ANOVA gives there): per factor the sum of squares of its level means about
//! the grand mean, its degrees of freedom, mean square, F = MS/MS_error and
//! p = P(F(dof, dof_error) > F). Orthogonality makes the factor sums of squares add up,
//! so the error is what is left: SS_error = SS_total − Σ SS_factor, from empty columns and
//! replicated runs.
//!
//! Six five-level factors in an L25 use all 24 degrees of freedom and leave none for the
//! error; then no F exists. Taguchi's remedy is pooling: the weakest effects (smallest
//! sums of squares) are declared error and their SS and dof move to the error term
//! ([`Pooling::Weakest`]). The other remedy is more runs: replicates or a larger array with
//! empty columns (both feed the error term here without an option). An F with zero error
//! degrees of freedom is refused, saying both.

use super::orthogonal::check_design;
use super::{CalibrationError, Result};
use statrs::distribution::{ContinuousCDF, FisherSnedecor};

/// Which effects go into the error term.
#[derive(Debug, Clone, PartialEq)]
pub enum Pooling {
    None,
    /// The n factors with the smallest sums of squares.
    Weakest(usize),
    /// The named factors.
    Factors(Vec<String>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Effect {
    pub factor: String,
    pub ss: f64,
    pub dof: usize,
    pub ms: f64,
    /// NaN for a pooled factor.
    pub f: f64,
    pub p: f64,
    pub pooled: bool,
    /// Mean response at each level (level 1 first).
    pub level_means: Vec<f64>,
    /// Critical F at the 0.05 and 0.01 levels for this factor's and the error's dof.
    pub f_crit_05: f64,
    pub f_crit_01: f64,
}

impl Effect {
    /// "**" when p ≤ 0.01 (very significant, paper 002), "*" when p ≤ 0.05, "" otherwise.
    pub fn significance(&self) -> &'static str {
        if self.pooled || !self.p.is_finite() {
            ""
        } else if self.p <= 0.01 {
            "**"
        } else if self.p <= 0.05 {
            "*"
        } else {
            ""
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Anova {
    pub effects: Vec<Effect>,
    pub ss_error: f64,
    pub dof_error: usize,
    pub ss_total: f64,
    pub dof_total: usize,
    pub grand_mean: f64,
    pub levels: usize,
}

impl Anova {
    pub fn ms_error(&self) -> f64 {
        self.ss_error / self.dof_error as f64
    }

    /// The effects by F, largest first (pooled last): the paper's order of influence.
    pub fn ranking(&self) -> Vec<&Effect> {
        let mut e: Vec<&Effect> = self.effects.iter().collect();
        e.sort_by(|a, b| {
            let key = |x: &Effect| if x.pooled { f64::NEG_INFINITY } else { x.f };
            key(b).total_cmp(&key(a))
        });
        e
    }

    /// A plain-text table for printing.
    pub fn to_text(&self) -> String {
        let mut s = format!("{:<14} {:>12} {:>4} {:>12} {:>10} {:>10}\n", "source", "SS", "dof", "MS", "F", "p");
        for e in &self.effects {
            if e.pooled {
                s += &format!(
                    "{:<14} {:>12.5e} {:>4} {:>12.5e} {:>10} {:>10}\n",
                    e.factor, e.ss, e.dof, e.ms, "(pooled)", ""
                );
            } else {
                s += &format!(
                    "{:<14} {:>12.5e} {:>4} {:>12.5e} {:>10.4} {:>10.3e} {}\n",
                    e.factor,
                    e.ss,
                    e.dof,
                    e.ms,
                    e.f,
                    e.p,
                    e.significance()
                );
            }
        }
        s += &format!("{:<14} {:>12.5e} {:>4} {:>12.5e}\n", "error", self.ss_error, self.dof_error, self.ms_error());
        s += &format!("{:<14} {:>12.5e} {:>4}\n", "total", self.ss_total, self.dof_total);
        s
    }
}

/// The main-effect ANOVA of `y[run]` over `design[run][factor]` (level indices 0 … q−1;
/// replicated runs are repeated rows). The design must be orthogonal (strength 2) so the
/// main effects are separable; `pooling` moves effects into the error term.
pub fn anova(design: &[Vec<u8>], levels: usize, names: &[String], y: &[f64], pooling: &Pooling) -> Result<Anova> {
    let n = design.len();
    if y.len() != n {
        return Err(CalibrationError::new(format!("{} responses for {n} runs: give one response per run", y.len())));
    }
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(CalibrationError::new(format!(
            "the response of run {} is {} — rerun or drop that point",
            i + 1,
            y[i]
        )));
    }
    let m = design.first().map_or(0, Vec::len);
    if names.len() != m {
        return Err(CalibrationError::new(format!("{} factor names for {m} design columns", names.len())));
    }
    check_design(design, levels).map_err(|e| {
        CalibrationError::new(format!("the ANOVA needs an orthogonal design (replicates repeat whole runs): {e}"))
    })?;
    let grand = y.iter().sum::<f64>() / n as f64;
    let ss_total: f64 = y.iter().map(|v| (v - grand).powi(2)).sum();
    // Sums of squares of responses near ±1e308 overflow to inf (or NaN), and F = inf/inf
    // then has no p; the statistics are the same in other units.
    if !(grand.is_finite() && ss_total.is_finite()) {
        let largest = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        return Err(CalibrationError::new(format!(
            "the responses are too large to square (|y| up to {largest:e}): scale them (e.g. divide by 1e6, or \
             give them in MPa rather than Pa) and analyse again; F and p do not change with the scale"
        )));
    }
    // Nothing varies: every sum of squares is 0 and F = 0/0 has no p.
    if ss_total == 0.0 {
        return Err(CalibrationError::new(format!(
            "all {n} responses are {}: nothing varies, so no factor has an effect to test; check that the \
             runs report the response they should (a metric that never changes)",
            y[0]
        )));
    }
    let per_level = (n / levels) as f64;
    let mut effects: Vec<Effect> = (0..m)
        .map(|j| {
            let mut sums = vec![0.0; levels];
            design.iter().zip(y).for_each(|(r, v)| sums[r[j] as usize] += v);
            let means: Vec<f64> = sums.iter().map(|s| s / per_level).collect();
            let ss = per_level * means.iter().map(|mu| (mu - grand).powi(2)).sum::<f64>();
            Effect {
                factor: names[j].clone(),
                ss,
                dof: levels - 1,
                ms: ss / (levels - 1) as f64,
                f: f64::NAN,
                p: f64::NAN,
                pooled: false,
                level_means: means,
                f_crit_05: f64::NAN,
                f_crit_01: f64::NAN,
            }
        })
        .collect();
    match pooling {
        Pooling::None => {}
        Pooling::Weakest(k) => {
            if *k >= m {
                return Err(CalibrationError::new(format!(
                    "cannot pool {k} of {m} factors: at least one must be tested"
                )));
            }
            let mut order: Vec<usize> = (0..m).collect();
            order.sort_by(|&a, &b| effects[a].ss.total_cmp(&effects[b].ss));
            order.iter().take(*k).for_each(|&j| effects[j].pooled = true);
        }
        Pooling::Factors(list) => {
            for name in list {
                let e = effects.iter_mut().find(|e| &e.factor == name).ok_or_else(|| {
                    CalibrationError::new(format!("cannot pool `{name}`: the factors are {}", names.join(", ")))
                })?;
                e.pooled = true;
            }
        }
    }
    let tested_ss: f64 = effects.iter().filter(|e| !e.pooled).map(|e| e.ss).sum();
    let tested_dof: usize = effects.iter().filter(|e| !e.pooled).map(|e| e.dof).sum();
    let dof_total = n - 1;
    let dof_error = dof_total - tested_dof;
    // Rounding may leave a tiny negative remainder where the factors explain everything.
    let ss_error = (ss_total - tested_ss).max(0.0);
    if dof_error == 0 {
        return Err(CalibrationError::new(format!(
            "no degrees of freedom are left for the error term: {m} factor(s) of {levels} levels use all {dof_total} \
             of the {n} runs, so no F can be computed. Pool the weakest effects into the error \
             (`pool: 1`, or `pool: [\"name\"]`), or add runs: replicates of the design or a larger array with empty columns"
        )));
    }
    let ms_error = ss_error / dof_error as f64;
    for e in effects.iter_mut().filter(|e| !e.pooled) {
        let dist = FisherSnedecor::new(e.dof as f64, dof_error as f64)
            .map_err(|err| CalibrationError::new(format!("F distribution ({}, {dof_error}): {err}", e.dof)))?;
        e.f = if ms_error > 0.0 {
            e.ms / ms_error
        } else if e.ms > 0.0 {
            f64::INFINITY
        } else {
            f64::NAN
        };
        // F is NaN only when both mean squares are 0 (a factor without effect and no error):
        // no p then, rather than asking the distribution for one (statrs panics on NaN).
        e.p = if e.f.is_nan() {
            f64::NAN
        } else if e.f.is_infinite() {
            0.0
        } else {
            dist.sf(e.f)
        };
        e.f_crit_05 = dist.inverse_cdf(0.95);
        e.f_crit_01 = dist.inverse_cdf(0.99);
    }
    Ok(Anova { effects, ss_error, dof_error, ss_total, dof_total, grand_mean: grand, levels })
}

/// A one-way analysis of variance of groups of any sizes (a completely randomised layout):
/// the between-group sum of squares Σ_k n_k·(ȳ_k − ȳ)², the within-group Σ_k Σ_i (y_ki − ȳ_k)²,
/// their degrees of freedom (g − 1, N − g), mean squares, F = MS_between/MS_within and
/// p = P(F(g − 1, N − g) > F).
#[derive(Debug, Clone, PartialEq)]
pub struct OneWay {
    pub ss_between: f64,
    pub ss_within: f64,
    pub ss_total: f64,
    pub dof_between: usize,
    pub dof_within: usize,
    pub dof_total: usize,
    pub ms_between: f64,
    pub ms_within: f64,
    pub f: f64,
    pub p: f64,
    pub grand_mean: f64,
    /// Each group's mean, in the order given.
    pub means: Vec<f64>,
}

/// The one-way ANOVA of `groups` (see [`OneWay`]). Sums are taken about each group's mean
/// and the grand mean (two passes), not from raw sums of squares, which lose the digits
/// of data with a large mean and a small spread (NIST's SiRstv: ~196 ± 0.1).
pub fn one_way(groups: &[Vec<f64>]) -> Result<OneWay> {
    if groups.len() < 2 {
        return Err(CalibrationError::new(format!(
            "{} group(s): a one-way ANOVA compares two or more groups",
            groups.len()
        )));
    }
    for (k, g) in groups.iter().enumerate() {
        if g.is_empty() {
            return Err(CalibrationError::new(format!("group {} is empty: give each group one value or more", k + 1)));
        }
        if let Some(i) = g.iter().position(|v| !v.is_finite()) {
            return Err(CalibrationError::new(format!(
                "group {}, value {} is {}: drop it first (f.select(f.is_finite()))",
                k + 1,
                i + 1,
                g[i]
            )));
        }
    }
    let n: usize = groups.iter().map(Vec::len).sum();
    let dof_between = groups.len() - 1;
    let dof_within = n - groups.len();
    if dof_within == 0 {
        return Err(CalibrationError::new(format!(
            "every one of the {} groups has a single value, so nothing is left to estimate the spread within groups; \
             give some group two values or more",
            groups.len()
        )));
    }
    let means: Vec<f64> = groups.iter().map(|g| g.iter().sum::<f64>() / g.len() as f64).collect();
    // The grand mean from the group means weighted by their sizes, then a correction pass.
    let rough = groups.iter().flatten().sum::<f64>() / n as f64;
    let grand = rough + groups.iter().flatten().map(|v| v - rough).sum::<f64>() / n as f64;
    let ss_between: f64 = groups.iter().zip(&means).map(|(g, m)| g.len() as f64 * (m - grand).powi(2)).sum();
    let ss_within: f64 = groups.iter().zip(&means).map(|(g, m)| g.iter().map(|v| (v - m).powi(2)).sum::<f64>()).sum();
    let ss_total: f64 = groups.iter().flatten().map(|v| (v - grand).powi(2)).sum();
    if !(ss_total.is_finite() && ss_between.is_finite() && ss_within.is_finite()) {
        return Err(CalibrationError::new(
            "the values are too large to square: scale them (e.g. give them in MPa rather than Pa); F and p do not change",
        ));
    }
    let (ms_between, ms_within) = (ss_between / dof_between as f64, ss_within / dof_within as f64);
    let f = if ms_within > 0.0 {
        ms_between / ms_within
    } else if ms_between > 0.0 {
        f64::INFINITY
    } else {
        f64::NAN
    };
    let dist = FisherSnedecor::new(dof_between as f64, dof_within as f64)
        .map_err(|e| CalibrationError::new(format!("F distribution ({dof_between}, {dof_within}): {e}")))?;
    // No spread at all: F = 0/0 has no p (statrs panics on NaN).
    let p = if f.is_nan() {
        f64::NAN
    } else if f.is_infinite() {
        0.0
    } else {
        dist.sf(f)
    };
    Ok(OneWay {
        ss_between,
        ss_within,
        ss_total,
        dof_between,
        dof_within,
        dof_total: n - 1,
        ms_between,
        ms_within,
        f,
        p,
        grand_mean: grand,
        means,
    })
}

#[cfg(test)]
mod tests {
    use super::super::orthogonal::OrthogonalArray;
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (1..=n).map(|i| format!("f{i}")).collect()
    }

    /// A one-way layout is the one-factor case of a main-effect ANOVA. NIST StRD SmLs01
    /// (9 treatments × 21 replicates; treatment means alternate 1.4, 1.3, 1.5, … and each
    /// treatment holds its mean once and ten pairs mean ± 0.1) has certified between-
    /// treatment SS 1.68 (dof 8), within SS 1.8 (dof 180) and F = 21.0.
    #[test]
    fn the_nist_smls01_one_way_layout_gives_its_certified_sums_of_squares_and_f() {
        let means = [1.4, 1.3, 1.5, 1.3, 1.5, 1.3, 1.5, 1.3, 1.5];
        let (mut design, mut y) = (Vec::new(), Vec::new());
        for (t, mu) in means.iter().enumerate() {
            design.push(vec![t as u8]);
            y.push(*mu);
            for _ in 0..10 {
                design.extend([vec![t as u8], vec![t as u8]]);
                y.extend([mu - 0.1, mu + 0.1]);
            }
        }
        let a = anova(&design, 9, &names(1), &y, &Pooling::None).unwrap();
        let e = &a.effects[0];
        assert!((e.ss - 1.68).abs() < 1e-12 && e.dof == 8, "{}", a.to_text());
        assert!((a.ss_error - 1.8).abs() < 1e-12 && a.dof_error == 180, "{}", a.to_text());
        assert!((e.f - 21.0).abs() < 1e-10, "F = {}", e.f);
        assert!(e.p < 1e-20 && e.significance() == "**");
    }

    /// Known effects on an L27(3^13): five 3-level factors with effects a_j·(−1, 0, 1) plus
    /// an error pattern that is an empty column's level contrast. The sums of squares are
    /// exactly 27/3·Σ effect², the error dof 16, and for 2 numerator dof the F distribution
    /// has the closed form P(F > f) = (1 + 2f/d₂)^(−d₂/2): the p values are checked against
    /// it, independently of the crate.
    #[test]
    fn known_effects_on_an_l27_are_recovered_with_f_and_p_against_the_closed_form() {
        let oa = OrthogonalArray::with_runs(27, 3).unwrap();
        let effects = [2.0, 1.0, 0.5, 0.1, 0.0];
        let noise = 0.3;
        let y: Vec<f64> = oa
            .rows
            .iter()
            .map(|r| {
                10.0 + effects.iter().enumerate().map(|(j, a)| a * (r[j] as f64 - 1.0)).sum::<f64>()
                    + noise * (r[12] as f64 - 1.0)
            })
            .collect();
        let design: Vec<Vec<u8>> = oa.rows.iter().map(|r| r[..5].to_vec()).collect();
        let a = anova(&design, 3, &names(5), &y, &Pooling::None).unwrap();
        assert_eq!(a.dof_error, 26 - 10);
        assert!((a.ss_error - 18.0 * noise * noise).abs() < 1e-10);
        let ms_e = 18.0 * noise * noise / 16.0;
        for (e, amp) in a.effects.iter().zip(effects) {
            // Level means are 10 − a, 10, 10 + a: SS = 9·2a².
            assert!((e.ss - 18.0 * amp * amp).abs() < 1e-10, "{}: {}", e.factor, e.ss);
            let f = 9.0 * amp * amp / ms_e;
            assert!((e.f - f).abs() < 1e-9 * f.max(1.0));
            let p = (1.0 + 2.0 * f / 16.0).powf(-8.0);
            assert!((e.p - p).abs() < 1e-9, "{}: p {} vs {p}", e.factor, e.p);
            // Critical F from the closed form: (1 + 2F/16)^−8 = α.
            let crit = |alpha: f64| 8.0 * (alpha.powf(-1.0 / 8.0) - 1.0);
            assert!((e.f_crit_05 - crit(0.05)).abs() < 1e-6 && (e.f_crit_01 - crit(0.01)).abs() < 1e-6);
        }
        let rank: Vec<&str> = a.ranking().iter().map(|e| e.factor.as_str()).collect();
        assert_eq!(rank, ["f1", "f2", "f3", "f4", "f5"]);
    }

    #[test]
    fn six_factors_in_an_l25_are_refused_without_pooling_and_tested_with_it() {
        let oa = OrthogonalArray::with_runs(25, 5).unwrap();
        let amp = [3.0, 2.0, 1.0, 0.5, 0.2, 0.05];
        let y: Vec<f64> = oa
            .rows
            .iter()
            .map(|r| amp.iter().enumerate().map(|(j, a)| a * (r[j] as f64 - 2.0).powi(2)).sum())
            .collect();
        let e = anova(&oa.rows, 5, &names(6), &y, &Pooling::None).unwrap_err().to_string();
        assert!(e.contains("no degrees of freedom") && e.contains("pool") && e.contains("replicates"), "{e}");
        let a = anova(&oa.rows, 5, &names(6), &y, &Pooling::Weakest(1)).unwrap();
        assert!(a.effects[5].pooled && a.dof_error == 4);
        // Levels (0…4 − 2)² = 4, 1, 0, 1, 4: mean 2, SS = 5·a²·Σ(v − 2)² = 5·14·a².
        for (e, a_j) in a.effects.iter().zip(amp) {
            assert!((e.ss - 70.0 * a_j * a_j).abs() < 1e-9, "{}", e.ss);
        }
        assert!((a.ss_error - 70.0 * 0.05f64.powi(2)).abs() < 1e-10);
        // Pooling by name gives the same table.
        let b = anova(&oa.rows, 5, &names(6), &y, &Pooling::Factors(vec!["f6".into()])).unwrap();
        assert_eq!(a.to_text(), b.to_text());
        assert!(a.effects[0].p < 1e-4 && a.effects[0].significance() == "**");
    }

    #[test]
    fn bad_input_is_named() {
        let oa = OrthogonalArray::with_runs(9, 3).unwrap();
        let e = anova(&oa.rows, 3, &names(4), &[1.0; 8], &Pooling::None).unwrap_err().to_string();
        assert!(e.contains("8 responses for 9 runs"), "{e}");
        let mut y = vec![1.0; 9];
        y[4] = f64::NAN;
        assert!(anova(&oa.rows, 3, &names(4), &y, &Pooling::Weakest(1)).unwrap_err().to_string().contains("run 5"));
        let e = anova(&oa.rows, 3, &names(4), &[2.5; 9], &Pooling::Weakest(1)).unwrap_err().to_string();
        assert!(e.contains("all 9 responses are 2.5"), "{e}");
        let huge: Vec<f64> = (0..9).map(|i| if i % 2 == 0 { 1e308 } else { -1e308 }).collect();
        let e = anova(&oa.rows, 3, &names(4), &huge, &Pooling::Weakest(1)).unwrap_err().to_string();
        assert!(e.contains("too large to square") && e.contains("scale"), "{e}");
        // A factor without effect and no error left: F and p are NaN, not a panic.
        let oa = OrthogonalArray::with_runs(9, 3).unwrap();
        let design: Vec<Vec<u8>> = oa.rows.iter().map(|r| r[..2].to_vec()).collect();
        let y: Vec<f64> = oa.rows.iter().map(|r| f64::from(r[0])).collect();
        let a = anova(&design, 3, &names(2), &y, &Pooling::None).unwrap();
        assert!(a.effects[1].p.is_nan() && a.effects[0].p == 0.0, "{}", a.to_text());
        let y: Vec<f64> = (0..9).map(f64::from).collect();
        assert!(anova(&oa.rows, 3, &names(4), &y, &Pooling::Factors(vec!["x".into()]))
            .unwrap_err()
            .to_string()
            .contains("cannot pool `x`"));
    }

    /// NIST StRD ANOVA data set SiRstv (lower difficulty, 5 instruments × 5 resistivity
    /// measurements of a silicon wafer, Ehrstein & Croarkin; certified values computed by NIST
    /// in 500-digit arithmetic, https://www.itl.nist.gov/div898/strd/anova/SiRstv.html):
    /// between instrument dof 4, SS 5.11462616000000E-02, MS 1.27865654000000E-02,
    /// F 1.18046237440255E+00; within instrument dof 20, SS 2.16636560000000E-01,
    /// MS 1.08318280000000E-02. Matched to 1e-8 relative (measured: 3.8e-13).
    #[test]
    fn one_way_anova_of_nist_sirstv_gives_its_certified_values() {
        let groups: Vec<Vec<f64>> = vec![
            vec![196.3052, 196.1240, 196.1890, 196.2569, 196.3403],
            vec![196.3042, 196.3825, 196.1669, 196.3257, 196.0422],
            vec![196.1303, 196.2005, 196.2889, 196.0343, 196.1811],
            vec![196.2795, 196.1748, 196.1494, 196.1485, 195.9885],
            vec![196.2119, 196.1051, 196.1850, 196.0052, 196.2090],
        ];
        let a = one_way(&groups).unwrap();
        let close = |x: f64, certified: f64| (x / certified - 1.0).abs();
        let worst = [
            close(a.ss_between, 5.11462616000000e-02),
            close(a.ms_between, 1.27865654000000e-02),
            close(a.f, 1.18046237440255e+00),
            close(a.ss_within, 2.16636560000000e-01),
            close(a.ms_within, 1.08318280000000e-02),
        ]
        .into_iter()
        .fold(0.0, f64::max);
        crate::eoutln!("SiRstv: worst relative difference from the certified values {worst:.2e}");
        assert!(worst < 1e-8, "{a:?}");
        assert_eq!((a.dof_between, a.dof_within, a.dof_total), (4, 20, 24));
        assert!((a.ss_total - a.ss_between - a.ss_within).abs() < 1e-12);
        // p for dof 4 and 20 from the closed form of the F distribution with an even numerator
        // dof: P(F > f) = x^(d2/2)·Σ_{k<d1/2} C(d2/2 + k − 1, k)·(1 − x)^k, x = d2/(d2 + d1·f).
        let x = 20.0 / (20.0 + 4.0 * a.f);
        let p = x.powi(10) * (1.0 + 10.0 * (1.0 - x));
        assert!((a.p - p).abs() < 1e-12, "p {} vs {p}", a.p);
    }

    /// Unequal groups (sizes 3, 5 and 2): the sums of squares against exact rational
    /// arithmetic (group means 3, 7, 5, grand mean 5.4; SS between 3·2.4² + 5·1.6² + 2·0.4² =
    /// 30.4, within 2 + 10 + 2 = 14), and p against the closed form for 2 numerator dof,
    /// (1 + 2F/d₂)^(−d₂/2).
    #[test]
    fn one_way_anova_of_unequal_groups_matches_exact_sums_and_the_closed_form_p() {
        let groups = vec![vec![2.0, 3.0, 4.0], vec![5.0, 6.0, 7.0, 8.0, 9.0], vec![4.0, 6.0]];
        let a = one_way(&groups).unwrap();
        assert!((a.ss_between - 30.4).abs() < 1e-12 && (a.ss_within - 14.0).abs() < 1e-12, "{a:?}");
        assert_eq!((a.dof_between, a.dof_within), (2, 7));
        let f = (30.4 / 2.0) / (14.0 / 7.0);
        assert!((a.f - f).abs() < 1e-12);
        assert!((a.p - (1.0 + 2.0 * f / 7.0).powf(-3.5)).abs() < 1e-12);
        assert_eq!(a.means, vec![3.0, 7.0, 5.0]);
        for bad in
            [vec![vec![1.0]], vec![vec![1.0], vec![]], vec![vec![1.0], vec![2.0]], vec![vec![1.0, f64::NAN], vec![2.0]]]
        {
            assert!(one_way(&bad).is_err(), "{bad:?}");
        }
    }
}
