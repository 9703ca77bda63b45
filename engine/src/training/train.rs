//! MatDEM's automatic training (paper 003 §3.1): start from the lattice conversion
//! formulas, measure E, ν, Tu, Cu and μi on a bonded random packing, correct, repeat.
//!
//! The first round uses the lattice formulas' micro parameters. Each correction moves the
//! micro parameter that mainly controls a property by the ratio of target to measured (Kn
//! for E, the breaking force Kn·Xb for Tu, Fs0 for Cu) or by the miss on the lattice scale
//! (Ks/Kn for ν, μp for μi); from the second correction on, each uses the secant of its
//! last two rounds, which learns how strongly the property responds.

use super::dimension::Dimension;
use super::fit::mohr_coulomb;
use super::lab_tests::{run_test, LabTest, Loading, TestResult};
use super::sample::{PackedSample, SampleSpec};
use crate::backend::RunControl;
use crate::error::{check_positive, Error, Result};
use crate::materials::{MacroProperties, Material};
use crate::provenance::Source;
use serde::{Deserialize, Serialize};
use std::f64::consts::SQRT_2;
use std::time::Instant;

/// Smallest μi the lattice formulas accept (μp = 0).
pub const MIN_INTERNAL_FRICTION: f64 = 1.0 / (2.0 * SQRT_2);

/// Confined tests end at this multiple of their expected peak strain.
pub const CONFINED_STRAIN_FACTOR: f64 = 2.5;

/// How close a round must come to the targets.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Tolerances {
    /// Relative, for E, Tu and Cu.
    pub strength: f64,
    /// Absolute, for ν.
    pub poisson: f64,
    /// Absolute, for μi.
    pub friction: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances { strength: 0.05, poisson: 0.02, friction: 0.05 }
    }
}

/// Training settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainOptions {
    pub sample: SampleSpec,
    pub density: f64,
    pub max_rounds: usize,
    /// Confining stresses of the confined tests, as fractions of the target Cu.
    pub confining: Vec<f64>,
    /// Loading rate: steps to reach the expected peak strain (Cu/E for compression).
    pub steps_to_peak: f64,
    pub tolerances: Tolerances,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            sample: SampleSpec::default(),
            density: 2650.0,
            max_rounds: 6,
            confining: vec![0.1, 0.2],
            steps_to_peak: 8000.0,
            tolerances: Tolerances::default(),
        }
    }
}

/// Refuses targets the conversion formulas of `dim` cannot start from, saying what to do instead.
pub fn validate_targets(t: &MacroProperties, dim: Dimension) -> Result<()> {
    let bad = |name: &'static str, v: f64, why: &str| Err(Error::param(name, v, why));
    if !(t.young.is_finite() && t.young > 0.0) {
        return bad("E", t.young, "Young's modulus must be a finite number > 0 Pa");
    }
    let nu_why = match dim {
        Dimension::Three => {
            "training needs 0 ≤ ν ≤ 0.2: above 0.2 the shear spring Ks would be negative (a bonded packing of \
             spheres cannot reach it); use ν ≤ 0.2"
        }
        Dimension::Two => {
            "training in 2D needs 0 ≤ ν ≤ 1/3: above it the shear spring Ks would be negative (a bonded layer \
             cannot reach it); use ν ≤ 1/3"
        }
    };
    if !(t.poisson.is_finite() && (0.0..=dim.max_poisson()).contains(&t.poisson)) {
        return bad("nu", t.poisson, nu_why);
    }
    for (name, v) in [("Tu", t.tensile), ("Cu", t.compressive)] {
        if !(v.is_finite() && v > 0.0) {
            return bad(name, v, "strengths must be finite numbers > 0 Pa");
        }
    }
    let mu_why = match dim {
        Dimension::Three => {
            "training needs μi ≥ 1/(2√2) ≈ 0.354 (below it the element friction μp would be negative); use μi ≥ 0.354"
        }
        Dimension::Two => {
            "training in 2D needs μi ≥ 1/(2√6) ≈ 0.204 (below it the element friction μp would be negative); use \
             μi ≥ 0.205"
        }
    };
    if !(t.internal_friction.is_finite() && t.internal_friction >= dim.min_internal_friction() - 1e-12) {
        return bad("mu_i", t.internal_friction, mu_why);
    }
    if t.tensile >= t.compressive {
        return bad("Tu", t.tensile, "the tensile strength must be smaller than the compressive strength Cu");
    }
    Ok(())
}

impl TrainOptions {
    pub fn validate(&self) -> Result<()> {
        self.sample.validate()?;
        check_positive("density", self.density, false)?;
        check_positive("steps_to_peak", self.steps_to_peak, false)?;
        if !(1..=20).contains(&self.max_rounds) {
            return Err(Error::param("rounds", self.max_rounds as f64, "must be 1 to 20 (MatDEM uses 4–6)"));
        }
        if self.confining.is_empty() || self.confining.iter().any(|c| !(c.is_finite() && *c > 0.0)) {
            return Err(Error::InvalidScene(
                "confining: give one or more confining stresses > 0, as fractions of Cu (e.g. [0.1, 0.2])".into(),
            ));
        }
        Ok(())
    }
}

/// The five properties measured on one material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    pub properties: MacroProperties,
    pub tests: Vec<TestResult>,
}

/// Measures E, ν, Cu (uniaxial compression), Tu (tension) and μi (Mohr–Coulomb through
/// the uniaxial and confined peaks) of `material` bonded onto `sample`.
pub fn measure(
    sample: &PackedSample,
    material: &Material,
    expected: &MacroProperties,
    opts: &TrainOptions,
    ctl: &RunControl,
) -> Result<Measurement> {
    let bonded = sample.bonded(material, ctl)?;
    let ucs_strain = expected.compressive / expected.young;
    let ucs = run_test(
        &bonded,
        LabTest::UniaxialCompression,
        &Loading::reaching_peak_in(opts.steps_to_peak, ucs_strain),
        ctl,
    )?;
    // The other tests' peaks are expected from this sample's own modulus, so every test
    // loads at the same number of steps to its peak whatever the round's stiffness.
    let usable = |x: f64, guess: f64| if x.is_finite() && x > 0.01 * guess && x < 100.0 * guess { x } else { guess };
    let e = usable(ucs.young, expected.young);
    let tension = run_test(
        &bonded,
        LabTest::UniaxialTension,
        &Loading::reaching_peak_in(opts.steps_to_peak, expected.tensile / e),
        ctl,
    )?;
    let mut peaks = vec![(0.0, ucs.peak_stress)];
    let n_phi = ((1.0 + expected.internal_friction.powi(2)).sqrt() + expected.internal_friction).powi(2);
    let mut tests = vec![ucs, tension];
    let cu = usable(tests[0].peak_stress, expected.compressive);
    let ucs_peak_strain = usable(tests[0].peak_strain, cu / e);
    for ratio in &opts.confining {
        let s3 = ratio * expected.compressive;
        // Peak expected on the target envelope's slope through this sample's own unconfined
        // peak. Confined bonded samples often harden without a clear peak: the strength is
        // then the largest stress within 2.5 times that strain.
        let strain = ucs_peak_strain * (cu + (n_phi - 1.0) * s3) / cu;
        let mut loading = Loading::reaching_peak_in(opts.steps_to_peak, strain);
        loading.max_strain_factor = CONFINED_STRAIN_FACTOR;
        let t = run_test(&bonded, LabTest::ConfinedCompression { confining: s3 }, &loading, ctl)?;
        peaks.push((s3, t.peak_stress));
        tests.push(t);
    }
    let mc = mohr_coulomb(&peaks);
    let properties = MacroProperties {
        young: tests[0].young,
        poisson: tests[0].poisson,
        tensile: tests[1].peak_stress,
        compressive: tests[0].peak_stress,
        internal_friction: mc.map_or(f64::NAN, |m| m.internal_friction),
    };
    Ok(Measurement { properties, tests })
}

/// One round of training.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Round {
    /// 1-based.
    pub round: usize,
    /// What the lattice formulas say this round's micro parameters give (for comparison).
    pub inputs: MacroProperties,
    pub material: Material,
    pub measured: MacroProperties,
    /// Largest error as a multiple of its tolerance (≤ 1: within every tolerance).
    pub score: f64,
    pub tests: Vec<TestResult>,
    pub wall_seconds: f64,
    pub steps: u64,
}

/// The outcome: every round, the best one, and whether it met the tolerances.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Training {
    pub name: String,
    pub targets: MacroProperties,
    pub options: TrainOptions,
    pub elements: usize,
    /// Mean element diameter the material was trained at (m).
    pub diameter: f64,
    pub packing_seconds: f64,
    pub rounds: Vec<Round>,
    /// Index into `rounds` of the closest round.
    pub best: usize,
    pub converged: bool,
}

impl Training {
    pub fn best_round(&self) -> &Round {
        &self.rounds[self.best]
    }

    /// The trained material file: the best round's material and what it was trained for.
    pub fn trained_material(&self) -> TrainedMaterial {
        let best = self.best_round();
        TrainedMaterial {
            material: best.material.clone(),
            diameter: self.diameter,
            targets: self.targets,
            measured: best.measured,
            converged: self.converged,
            round: best.round,
            elements: self.elements,
            dimension: self.options.sample.dimension,
        }
    }
}

/// What a material file holds: micro parameters and the element size they belong to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainedMaterial {
    pub material: Material,
    /// Mean element diameter the micro parameters are for (m).
    pub diameter: f64,
    pub targets: MacroProperties,
    pub measured: MacroProperties,
    pub converged: bool,
    pub round: usize,
    pub elements: usize,
    /// Trained on a 3D or a 2D sample: a 2D material belongs in 2D models. Files written before
    /// 2D training read as 3D.
    #[serde(default)]
    pub dimension: Dimension,
}

impl TrainedMaterial {
    /// The trained material, its micro values marked as trained (for which targets, at which
    /// diameter, in which round).
    pub fn material(&self) -> Material {
        let mut material = self.material.clone();
        let t = &self.targets;
        let what = format!(
            "round {} of MatDEM's training for E {:.4e} Pa, ν {}, Tu {:.4e} Pa, Cu {:.4e} Pa, μi {} at d = {:.4e} m \
             ({})",
            self.round,
            t.young,
            t.poisson,
            t.tensile,
            t.compressive,
            t.internal_friction,
            self.diameter,
            if self.converged { "converged" } else { "not converged: the best round" }
        );
        material.provenance.set_all(&["kn", "ks", "xb", "fs0", "mu_p"], Source::Trained(what));
        material
    }

    /// For elements of mean diameter `d` (paper 001 §2): Kn/d, Kn/Ks and the strengths kept.
    pub fn for_diameter(&self, d: f64) -> Result<Material> {
        self.material().rescaled(self.diameter, d)
    }
}

/// Errors as multiples of their tolerances; the largest is the round's score.
pub fn score(measured: &MacroProperties, targets: &MacroProperties, tol: &Tolerances) -> f64 {
    let rel = |m: f64, t: f64| ((m - t) / t).abs();
    let errs = [
        rel(measured.young, targets.young) / tol.strength,
        (measured.poisson - targets.poisson).abs() / tol.poisson,
        rel(measured.tensile, targets.tensile) / tol.strength,
        rel(measured.compressive, targets.compressive) / tol.strength,
        (measured.internal_friction - targets.internal_friction).abs() / tol.friction,
    ];
    // A NaN (no envelope) counts as failing.
    errs.iter().map(|e| if e.is_nan() { f64::INFINITY } else { *e }).fold(0.0, f64::max)
}

/// Trains a material named `name` to `targets`. `on_round` sees each round as it ends.
pub fn train(
    name: &str,
    targets: &MacroProperties,
    opts: &TrainOptions,
    ctl: &RunControl,
    on_round: &mut dyn FnMut(&Round),
) -> Result<Training> {
    let dim = opts.sample.dimension;
    validate_targets(targets, dim)?;
    opts.validate()?;
    let d = 2.0 * opts.sample.radius;
    let start = Instant::now();
    let first = dim.material(name, opts.density, targets, d)?;
    let sample = PackedSample::pack(&opts.sample, &first, ctl)?;
    let packing_seconds = start.elapsed().as_secs_f64();
    let d = sample.diameter();
    let mut material = dim.material(name, opts.density, targets, d)?;
    let mut rounds: Vec<Round> = Vec::new();
    for k in 0..opts.max_rounds {
        let t0 = Instant::now();
        material.validate()?;
        let inputs = dim.lattice_macro(&material, d);
        let m = measure(&sample, &material, targets, opts, ctl)?;
        let round = Round {
            round: k + 1,
            inputs,
            material: material.clone(),
            measured: m.properties,
            score: score(&m.properties, targets, &opts.tolerances),
            steps: m.tests.iter().map(|t| t.steps).sum(),
            tests: m.tests,
            wall_seconds: t0.elapsed().as_secs_f64(),
        };
        on_round(&round);
        let done = round.score <= 1.0;
        rounds.push(round);
        if done {
            break;
        }
        material = corrected(&rounds, targets, d, dim);
    }
    let best = (0..rounds.len()).min_by(|&a, &b| rounds[a].score.total_cmp(&rounds[b].score)).unwrap_or(0);
    Ok(Training {
        name: name.to_string(),
        targets: *targets,
        options: opts.clone(),
        elements: sample.len(),
        diameter: d,
        packing_seconds,
        converged: rounds[best].score <= 1.0,
        best,
        rounds,
    })
}

/// The next round's micro parameters from the rounds so far. Each micro parameter follows
/// the property it mainly controls: Kn ← E, Ks/Kn ← ν, Kn·Xb (the breaking force) ← Tu,
/// Fs0 ← Cu, μp ← μi. ν and μi are corrected on the lattice formulas' scale (ν from Ks/Kn,
/// μi from μp), so a correction means the same at any starting point.
fn corrected(rounds: &[Round], t: &MacroProperties, d: f64, dim: Dimension) -> Material {
    let last = rounds.last().expect("at least one round");
    let prev = (rounds.len() >= 2).then(|| &rounds[rounds.len() - 2]);
    let (mat, m) = (&last.material, &last.measured);
    // Ratio of target to measured, with the exponent learnt from the last two rounds
    // (measured ∝ parameter^p in log–log; p = 1 until there is a usable secant).
    let ratio = |param: fn(&Material) -> f64, get: fn(&MacroProperties) -> f64| -> f64 {
        let (x, mi, ti) = (param(mat), get(m), get(t));
        if !(mi.is_finite() && mi > 0.0) {
            return 1.0;
        }
        let p = prev
            .and_then(|r| {
                let (dx, dm) = ((x / param(&r.material)).ln(), (mi / get(&r.measured)).ln());
                let p = dm / dx;
                (dx.abs() > 0.01 && p.is_finite() && p > 0.1).then(|| p.clamp(0.3, 3.0))
            })
            .unwrap_or(1.0);
        // The first correction may be large (the lattice formulas can be far off for a
        // random packing); later ones at most a factor 3, so one noisy round cannot derail.
        let limit = if prev.is_none() { 10.0 } else { 3.0 };
        (ti / mi).powf(1.0 / p).clamp(1.0 / limit, limit)
    };
    // A shift of the lattice value by the miss, over the secant slope, limited per round.
    let shift = |lattice: fn(&MacroProperties) -> f64, get: fn(&MacroProperties) -> f64, max_step: f64| -> f64 {
        let here = lattice(&dim.lattice_macro(mat, d));
        let (mi, ti) = (get(m), get(t));
        if !mi.is_finite() {
            return here;
        }
        let slope = prev
            .and_then(|r| {
                let (dx, dm) = (here - lattice(&dim.lattice_macro(&r.material, d)), mi - get(&r.measured));
                let k = dm / dx;
                (dx.abs() > 1e-3 && k.is_finite() && k > 0.1).then(|| k.clamp(0.5, 2.0))
            })
            .unwrap_or(1.0);
        here + ((ti - mi) / slope).clamp(-max_step, max_step)
    };
    let mut next = mat.clone();
    let s_old = mat.ks / mat.kn;
    // ν = (1 − s)/(5 + s) on the 3D lattice (2D: (1 − s)/(3 + s)); s from ν.
    let nu = shift(|p| p.poisson, |p| p.poisson, 0.08).clamp(0.0, dim.max_poisson());
    let s_new = dim.shear_ratio(nu);
    // Lattice E ∝ Kn·(1 + s)/(5 + s) (2D: (3 + s)): keep the change of s from moving E.
    next.kn = mat.kn * ratio(|x| x.kn, |p| p.young) * dim.young_factor(s_old) / dim.young_factor(s_new);
    next.ks = s_new * next.kn;
    let breaking_force = mat.kn * mat.xb * ratio(|x| x.kn * x.xb, |p| p.tensile);
    next.xb = breaking_force / next.kn;
    next.fs0 = mat.fs0 * ratio(|x| x.fs0, |p| p.compressive);
    let mu_i = shift(|p| p.internal_friction, |p| p.internal_friction, 0.3).max(dim.min_internal_friction());
    next.mu_p = dim.mu_p(mu_i);
    next
}
