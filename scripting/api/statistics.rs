//! Statistics of whole arrays: percentiles (and the median) and histograms of a `Field`,
//! e.g. the distribution of displacements, contact loads or radii in a region; and the
//! one-way analysis of variance of groups of any sizes (`anova_oneway`).
//!
//! Conventions are NumPy's defaults, so numbers match a user's notebook: a percentile
//! interpolates linearly between order statistics (rank (n − 1)·p/100); histogram bins are
//! [eₖ, eₖ₊₁) except the last, which includes its upper edge. A NaN or infinite element is
//! refused by index (select the finite ones first), as the reductions do.

use super::arrays::{to_numbers, Field};
use super::{err, RhaiResult};
use rhai::{Array, Dynamic, Engine, Map, INT};

/// The documentation of every name registered here: (name, usage, what it does).
pub const DOCS: &[(&str, &str, &str)] = &[
    ("percentile", "f.percentile(p) -> f64", "the p-th percentile (0 ≤ p ≤ 100), linear between order statistics (NumPy's default); refuses an empty field and NaN/inf elements, naming the first"),
    ("percentiles", "f.percentiles([p1, p2, …]) -> Field", "several percentiles at once (one sort)"),
    ("median", "f.median() -> f64", "the 50th percentile"),
    ("anova_oneway", "anova_oneway([f1, f2, …]) -> map", "one-way analysis of variance of two or more groups of any sizes (Fields or arrays of numbers): #{ ss_between, ss_within, ss_total, dof_between, dof_within, dof_total, ms_between, ms_within, f, p, grand_mean, means } with F = MS_between/MS_within and p = P(F(g − 1, N − g) > F); checked against NIST StRD SiRstv"),
    ("histogram", "f.histogram(bins) / f.histogram(edges) -> map", "counts per bin: bins equal bins over [min, max], or the bins between increasing edges (each [eₖ, eₖ₊₁), the last closed); #{ edges: Field, counts: Field, outside: int } (values beyond the edges are counted in outside)"),
];

/// The values sorted, after refusing an empty field and non-finite elements.
fn sorted(f: &Field, what: &str) -> RhaiResult<Vec<f64>> {
    if f.0.is_empty() {
        return Err(err(format!(
            "{what} of an empty field (0 values): the selection is empty; check `mask.count() > 0` first"
        )));
    }
    finite(f, what)?;
    let mut v = f.0.to_vec();
    v.sort_by(f64::total_cmp);
    Ok(v)
}

fn finite(f: &Field, what: &str) -> RhaiResult<()> {
    match f.0.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(err(format!(
            "{what}: element {i} is {} (a missing or diverged value); use the finite values: \
             `f.select(f.is_finite()).{what}(…)`",
            f.0[i]
        ))),
        None => Ok(()),
    }
}

/// The p-th percentile of sorted values, linear between order statistics.
fn at(sorted: &[f64], p: f64, what: &str) -> RhaiResult<f64> {
    if !(0.0..=100.0).contains(&p) {
        return Err(err(format!("{what}: p = {p}; a percentile is between 0 and 100")));
    }
    let h = (sorted.len() - 1) as f64 * p / 100.0;
    let (k, frac) = (h.floor() as usize, h - h.floor());
    let next = sorted[(k + 1).min(sorted.len() - 1)];
    Ok(sorted[k] + frac * (next - sorted[k]))
}

fn number(v: &Dynamic, what: &str) -> RhaiResult<f64> {
    super::arrays::number(v).ok_or_else(|| err(format!("{what}: expected a number, got {}", v.type_name())))
}

/// Counts of `values` per bin between `edges` (increasing), and how many fell outside.
fn count(values: &[f64], edges: &[f64]) -> (Vec<f64>, INT) {
    let bins = edges.len() - 1;
    let mut counts = vec![0.0; bins];
    let mut outside = 0;
    for &x in values {
        if x < edges[0] || x > edges[bins] {
            outside += 1;
            continue;
        }
        // The last edge closes the last bin.
        let k = edges.partition_point(|e| *e <= x).saturating_sub(1).min(bins - 1);
        counts[k] += 1.0;
    }
    (counts, outside)
}

fn histogram_map(edges: Vec<f64>, counts: Vec<f64>, outside: INT) -> Map {
    Map::from_iter([
        ("edges".into(), Dynamic::from(Field::new(edges))),
        ("counts".into(), Dynamic::from(Field::new(counts))),
        ("outside".into(), Dynamic::from_int(outside)),
    ])
}

/// `anova_oneway`'s map.
fn one_way(groups: Array) -> RhaiResult<Map> {
    let groups = groups
        .iter()
        .enumerate()
        .map(|(k, g)| to_numbers(g, &format!("anova_oneway: group {}", k + 1)))
        .collect::<RhaiResult<Vec<_>>>()?;
    let a = crate::calibration::anova::one_way(&groups).map_err(|e| err(format!("anova_oneway: {e}")))?;
    let mut m = Map::new();
    for (k, v) in [
        ("ss_between", a.ss_between),
        ("ss_within", a.ss_within),
        ("ss_total", a.ss_total),
        ("ms_between", a.ms_between),
        ("ms_within", a.ms_within),
        ("f", a.f),
        ("p", a.p),
        ("grand_mean", a.grand_mean),
    ] {
        m.insert(k.into(), Dynamic::from_float(v));
    }
    for (k, v) in [("dof_between", a.dof_between), ("dof_within", a.dof_within), ("dof_total", a.dof_total)] {
        m.insert(k.into(), Dynamic::from_int(v as INT));
    }
    m.insert("means".into(), Dynamic::from(Field::new(a.means)));
    Ok(m)
}

pub fn register(engine: &mut Engine) {
    engine.register_fn("anova_oneway", one_way);
    engine
        .register_fn("percentile", |f: &mut Field, p: Dynamic| -> RhaiResult<f64> {
            let p = number(&p, "percentile")?;
            at(&sorted(f, "percentile")?, p, "percentile")
        })
        .register_fn("percentiles", |f: &mut Field, ps: Array| -> RhaiResult<Field> {
            let ps = to_numbers(&Dynamic::from_array(ps), "percentiles")?;
            let v = sorted(f, "percentiles")?;
            ps.iter().map(|p| at(&v, *p, "percentiles")).collect::<RhaiResult<Vec<_>>>().map(Field::new)
        })
        .register_fn("median", |f: &mut Field| -> RhaiResult<f64> { at(&sorted(f, "median")?, 50.0, "median") })
        .register_fn("histogram", |f: &mut Field, spec: Dynamic| -> RhaiResult<Map> {
            if let Ok(bins) = spec.as_int() {
                if !(1..=1_000_000).contains(&bins) {
                    return Err(err(format!("histogram: {bins} bins; give 1 to 1000000 bins, or the bin edges")));
                }
                let v = sorted(f, "histogram")?;
                let (mut lo, mut hi) = (v[0], v[v.len() - 1]);
                if lo == hi {
                    // One value: a unit-wide range around it, as NumPy does.
                    (lo, hi) = (lo - 0.5, hi + 0.5);
                }
                let edges: Vec<f64> = (0..=bins).map(|k| lo + (hi - lo) * k as f64 / bins as f64).collect();
                let (counts, outside) = count(&v, &edges);
                return Ok(histogram_map(edges, counts, outside));
            }
            let edges = to_numbers(&spec, "histogram: edges").map_err(|_| {
                err(format!("histogram: expected a number of bins or an array of bin edges, got {}", spec.type_name()))
            })?;
            if edges.len() < 2 {
                return Err(err(format!("histogram: give at least 2 edges (one bin), got {}", edges.len())));
            }
            if let Some(k) = (0..edges.len()).find(|&k| !edges[k].is_finite() || (k > 0 && edges[k] <= edges[k - 1])) {
                return Err(err(format!(
                    "histogram: edge {k} is {}; the edges must be finite and strictly increasing",
                    edges[k]
                )));
            }
            finite(f, "histogram")?;
            let (counts, outside) = count(&f.0, &edges);
            Ok(histogram_map(edges, counts, outside))
        });
}
