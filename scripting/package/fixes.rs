//! A guard's fix against what a packaged simulator lets its user set. The engine puts the
//! numbers of a fix on its error ([`Instability::suggest`]: a quantity by the name scripts set
//! it under, and the side of a bound the run needs it on); a package's user can only change
//! its parameters, within their ranges. So when a package's run stops, each number is checked
//! against the parameter of the same name, and the message says which fixes lie within the
//! ranges (with a `--set` that does it) and which do not.
//!
//! A parameter matches a suggestion by name (`bulk_modulus`, `viscosity`, `nusselt`,
//! `max_substeps`), and the time step `dt` also matches a parameter whose unit is
//! [`STANDARD_DT_UNIT`] (the examples' `dt_rate`: dt in MatDEM's standard steps).

use super::{ParamType, Parameter};
use matdem_engine::error::{Instability, Side, Suggestion};

/// The unit that makes a parameter the time step in MatDEM's standard steps (dt / standard
/// dt): the engine's `dt` fixes are checked against it, divided by the standard step.
pub const STANDARD_DT_UNIT: &str = "× standard dt";

/// How far past its bound a suggested value is put: the engine's bounds come from estimates
/// (the stiff fluid's is an upper bound on the fluid's spring; half the bulk modulus it names
/// ran in its test), so the value offered keeps a margin of 2, or stops at the range's end.
const MARGIN: f64 = 2.0;

/// One suggestion, checked.
enum Checked {
    /// `--set NAME=VALUE` lies in the range and past the bound.
    Within { what: String, set: String },
    /// The parameter exists, but its range stops short of the bound.
    Outside { what: String },
    /// No parameter of the package sets this quantity.
    Absent { name: &'static str },
}

/// The note to add to an instability's message in a package whose parameters are `params`:
/// each suggested fix checked against the parameter that sets it. `None` when the run is not
/// a package's (no parameters) or the fix has no numbers.
pub fn fixes_in_range(params: &[Parameter], inst: &Instability) -> Option<String> {
    if params.is_empty() || inst.suggest.is_empty() {
        return None;
    }
    let checked: Vec<Checked> = inst.suggest.iter().map(|s| check(params, s, inst.standard_dt)).collect();
    let mut clauses: Vec<String> = checked
        .iter()
        .filter_map(|c| match c {
            Checked::Within { what, .. } | Checked::Outside { what } => Some(what.clone()),
            Checked::Absent { .. } => None,
        })
        .collect();
    let absent: Vec<&str> =
        checked.iter().filter_map(|c| if let Checked::Absent { name } = c { Some(*name) } else { None }).collect();
    if !absent.is_empty() {
        clauses.push(format!("{} {} not among its parameters", absent.join(", "), plural(absent.len(), "is", "are")));
    }
    let sets: Vec<&str> = checked
        .iter()
        .filter_map(|c| if let Checked::Within { set, .. } = c { Some(set.as_str()) } else { None })
        .collect();
    let verdict = if sets.is_empty() {
        "None of these fixes lies within this simulator's parameters: change the scene (its script), or widen a \
         range in its simulator.ron where the physics allows"
            .to_string()
    } else {
        format!("Within its ranges: {}", sets.join(", or "))
    };
    Some(format!("In this simulator (its parameters' ranges): {}. {verdict}.", clauses.join("; ")))
}

fn plural<'a>(n: usize, one: &'a str, many: &'a str) -> &'a str {
    if n == 1 {
        one
    } else {
        many
    }
}

/// Checks one suggestion against the parameter that sets its quantity.
fn check(params: &[Parameter], s: &Suggestion, standard_dt: f64) -> Checked {
    let numeric = |p: &&Parameter| matches!(p.kind, ParamType::Int | ParamType::Float);
    let side = match s.side {
        Side::Below => "below",
        Side::Above => "above",
    };
    let unit = if s.unit.is_empty() { String::new() } else { format!(" {}", s.unit) };
    let asked = format!("{} {side} {:.3e}{unit}", s.parameter, s.bound);
    let (p, bound, what) = match params.iter().filter(numeric).find(|p| p.name == s.parameter) {
        Some(p) => (p, s.bound, asked),
        None => {
            let in_steps = (s.parameter == "dt" && standard_dt.is_finite() && standard_dt > 0.0)
                .then(|| params.iter().filter(numeric).find(|p| p.unit.as_deref() == Some(STANDARD_DT_UNIT)))
                .flatten();
            match in_steps {
                Some(p) => {
                    let bound = s.bound / standard_dt;
                    (p, bound, format!("{asked}, that is {} {side} {} ({STANDARD_DT_UNIT}),", p.name, short(bound)))
                }
                None => return Checked::Absent { name: s.parameter },
            }
        }
    };
    let (lo, hi) = p.range.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let range = match p.range {
        Some((lo, hi)) => format!("its range {} … {}", short(lo), short(hi)),
        None => "any value".to_string(),
    };
    match offer(p.kind, s.side, bound, lo, hi) {
        Some(set) => {
            Checked::Within { what: format!("{what} lies within {range}"), set: format!("--set {}={set}", p.name) }
        }
        None => Checked::Outside { what: format!("{what} lies outside {range}") },
    }
}

/// A value past `bound` on `side`, within [lo, hi], as `--set` takes it: `MARGIN` past the
/// bound or the range's end, whichever is nearer; `None` when the range stops short of it.
fn offer(kind: ParamType, side: Side, bound: f64, lo: f64, hi: f64) -> Option<String> {
    let past = |x: f64| match side {
        Side::Below => x < bound,
        Side::Above => x > bound,
    };
    let fits = |x: f64| x.is_finite() && (lo..=hi).contains(&x) && past(x);
    let wanted = match side {
        Side::Below => (bound / MARGIN).max(lo),
        Side::Above => (bound * MARGIN).min(hi),
    };
    if kind == ParamType::Int {
        let v = match side {
            Side::Below => wanted.floor(),
            Side::Above => wanted.ceil(),
        };
        return fits(v).then(|| format!("{}", v as i64));
    }
    if !fits(wanted) {
        return None;
    }
    // Three significant digits, unless rounding leaves the range or crosses the bound.
    let text = short(wanted);
    Some(if text.parse::<f64>().is_ok_and(fits) { text } else { format!("{wanted}") })
}

/// A number to three significant digits, as `--set` takes it: 0.0186, 2.5, 1.37e10.
fn short(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor();
    if !(-3.0..5.0).contains(&mag) {
        let s = format!("{x:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        return format!("{}e{e}", trim(m));
    }
    let decimals = (2.0 - mag).max(0.0) as usize;
    trim(&format!("{x:.decimals$}")).to_string()
}

/// "1.50" → "1.5", "2.00" → "2", "300" stays.
fn trim(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn param(ron_text: &str) -> Parameter {
        super::super::ron_options().from_str(ron_text).unwrap()
    }

    fn stiff_fluid() -> Instability {
        Instability {
            step: 8,
            particle: 34,
            what: "bounds pore 60".into(),
            dt: 1.047e-7,
            critical_dt: 3.895e-9,
            standard_dt: 1.047e-7,
            fix: None,
            suggest: vec![Suggestion::below("bulk_modulus", 1.374e10, "Pa"), Suggestion::below("dt", 3.895e-9, "s")],
        }
    }

    #[test]
    fn numbers_are_written_to_three_digits_as_set_takes_them() {
        for (x, s) in [(0.0186, "0.0186"), (2.5, "2.5"), (1.374e10, "1.37e10"), (300.0, "300"), (1e5, "1e5")] {
            assert_eq!(short(x), s);
        }
    }

    // The stiff fluid's K_f lies under the package's range: the note says so and offers the
    // other fix, dt, through the parameter in standard steps.
    #[test]
    fn a_fix_below_the_range_is_named_outside_and_the_other_offered() {
        let params = [
            param(r#"(name: "bulk_modulus", type: float, unit: "Pa", range: (1e11, 1e14))"#),
            param(r#"(name: "dt_rate", type: float, unit: "× standard dt", range: (0.01, 1.0))"#),
        ];
        let note = fixes_in_range(&params, &stiff_fluid()).unwrap();
        assert!(note.contains("bulk_modulus below 1.374e10 Pa lies outside its range 1e11 … 1e14"), "{note}");
        assert!(
            note.contains(
                "dt below 3.895e-9 s, that is dt_rate below 0.0372 (× standard dt), lies within its range 0.01 … 1"
            ),
            "{note}"
        );
        assert!(note.contains("Within its ranges: --set dt_rate=0.0186"), "{note}");
    }

    #[test]
    fn without_a_parameter_in_range_the_note_says_to_change_the_scene() {
        let params = [param(r#"(name: "bulk_modulus", type: float, unit: "Pa", range: (1e11, 1e14))"#)];
        let note = fixes_in_range(&params, &stiff_fluid()).unwrap();
        assert!(note.contains("dt is not among its parameters"), "{note}");
        assert!(note.contains("None of these fixes lies within"), "{note}");
        assert!(fixes_in_range(&[], &stiff_fluid()).is_none(), "a plain script gets no note");
    }

    // A range that reaches past the bound, but not by the margin: the offer is its end.
    #[test]
    fn an_offer_stops_at_the_ranges_end_and_ints_round_outward() {
        let params = [
            param(r#"(name: "bulk_modulus", type: float, unit: "Pa", range: (1e10, 1e14))"#),
            param(r#"(name: "max_substeps", type: int, range: (1, 100))"#),
        ];
        let mut inst = stiff_fluid();
        inst.suggest.push(Suggestion::above("max_substeps", 40.0, ""));
        let note = fixes_in_range(&params, &inst).unwrap();
        assert!(note.contains("--set bulk_modulus=1e10"), "{note}");
        assert!(note.contains("--set max_substeps=80"), "{note}");
        inst.suggest[2].bound = 99.5;
        let note = fixes_in_range(&params, &inst).unwrap();
        assert!(note.contains("--set max_substeps=100"), "{note}");
    }
}
