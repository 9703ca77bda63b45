//! The calibration toolkit for scripts (paper 002): orthogonal designs, main-effect ANOVA,
//! single-factor regressions, a response surface with its multi-factor inversion, generic
//! Levenberg–Marquardt on a script function, and the Mohr–Coulomb fit; charts of each.
//! The numerics live in `crate::calibration`; this file converts and draws.

use super::arrays::{to_numbers, Field};
use super::options::check_keys;
use super::plot::save_figure;
use super::table::{Table, TableData};
use super::{err, write_atomic, Host, RhaiResult};
use crate::calibration::anova::{self, Anova, Pooling};
use crate::calibration::levenberg_marquardt::{minimise, Options};
use crate::calibration::orthogonal::{self, OrthogonalArray};
use crate::calibration::refine::Refinement;
use crate::calibration::regression::{self, Fit, Form};
use crate::calibration::response_surface::{Inversion, Surface};
use crate::calibration::{mohr_coulomb, CalibrationError};
use crate::plot::{BarChart, Figure, LineChart};
use rhai::{Array, Dynamic, Engine, FnPtr, Map, NativeCallContext, FLOAT, INT};
use std::cell::RefCell;
use std::rc::Rc;

/// An orthogonal design: the array and, per factor, its name and level values.
#[derive(Debug, Clone)]
pub struct Design {
    pub array: OrthogonalArray,
    pub factors: Vec<String>,
    /// `values[factor][level]`.
    pub values: Vec<Vec<f64>>,
}

impl Design {
    /// The factor columns of the array (the rest are empty columns).
    fn levels_used(&self) -> Vec<Vec<u8>> {
        self.array.rows.iter().map(|r| r[..self.factors.len()].to_vec()).collect()
    }

    fn value(&self, run: usize, j: usize) -> f64 {
        self.values[j][self.array.rows[run][j] as usize]
    }

    fn point(&self, run: usize) -> Map {
        self.factors
            .iter()
            .enumerate()
            .map(|(j, n)| (n.as_str().into(), Dynamic::from_float(self.value(run, j))))
            .collect()
    }

    fn table(&self) -> TableData {
        let mut t = TableData::default();
        for run in 0..self.array.runs() {
            let mut row = vec![("run".to_string(), (run + 1) as f64)];
            row.extend(self.factors.iter().enumerate().map(|(j, n)| (n.clone(), self.value(run, j))));
            t.push(&row);
        }
        t
    }

    fn factor(&self, name: &str) -> RhaiResult<usize> {
        self.factors.iter().position(|f| f == name).ok_or_else(|| {
            err(format!(
                "design {}: no factor `{name}`; its factors are {}",
                self.array.name(),
                self.factors.join(", ")
            ))
        })
    }
}

/// An ANOVA of one response over a design.
#[derive(Debug, Clone)]
pub struct AnovaResult {
    pub anova: Anova,
    pub response: String,
    pub design: Rc<Design>,
}

/// The fits of one response against one factor, best first.
#[derive(Debug, Clone)]
pub struct Regression {
    pub fits: Vec<Fit>,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

#[derive(Debug, Clone)]
pub struct ResponseSurface(pub Rc<Surface>);

/// An inversion refined by confirmation runs (`s.refinement(targets, held)`); shared, so a
/// copy of the variable refines the same loop.
#[derive(Debug, Clone)]
pub struct ScriptRefinement(pub Rc<RefCell<Refinement>>);

fn inversion_map(s: &Surface, targets: &[String], inv: &Inversion) -> Map {
    let mut m = Map::new();
    let point: Map =
        s.factors.iter().zip(&inv.point).map(|(n, v)| (n.as_str().into(), Dynamic::from_float(*v))).collect();
    let predicted: Map =
        s.responses.iter().zip(&inv.predicted).map(|(n, v)| (n.as_str().into(), Dynamic::from_float(*v))).collect();
    let errors: Map =
        targets.iter().zip(&inv.relative_errors).map(|(n, e)| (n.as_str().into(), Dynamic::from_float(*e))).collect();
    m.insert("point".into(), point.into());
    m.insert("predicted".into(), predicted.into());
    m.insert("errors".into(), errors.into());
    m.insert("converged".into(), inv.converged.into());
    m
}

/// The values of `names` from a map, in that order; `what` names the call in errors.
fn values_of(m: &Map, names: &[String], what: &str) -> RhaiResult<Vec<f64>> {
    names
        .iter()
        .map(|n| {
            let v = m.get(n.as_str()).ok_or_else(|| {
                err(format!("{what}: `{n}` is missing; give a number for each of: {}", names.join(", ")))
            })?;
            super::arrays::number(v)
                .ok_or_else(|| err(format!("{what}: `{n}` is a {}, expected a number", v.type_name())))
        })
        .collect()
}

fn cal(what: &str) -> impl Fn(CalibrationError) -> Box<rhai::EvalAltResult> + '_ {
    move |e| err(format!("{what}: {e}"))
}

fn names_of(v: &Array, what: &str) -> RhaiResult<Vec<String>> {
    v.iter()
        .enumerate()
        .map(|(i, n)| {
            n.clone()
                .into_string()
                .map_err(|_| err(format!("{what}: element {i} is a {}, expected a name", n.type_name())))
        })
        .collect()
}

/// The error of a construction or check of a design: a signal's cancellation stops the
/// script as a signal does (see [`super::cancelled`]).
fn design_err<'a>(host: &'a Host, what: &'a str) -> impl Fn(CalibrationError) -> Box<rhai::EvalAltResult> + 'a {
    move |e| if orthogonal::is_cancellation(&e) { super::cancelled(host) } else { err(format!("{what}: {e}")) }
}

fn design_of_values(host: &Host, names: Vec<String>, values: Vec<Vec<f64>>) -> RhaiResult<Design> {
    if names.len() != values.len() || names.is_empty() {
        return Err(err(format!("orthogonal_design: {} name(s) for {} list(s) of levels", names.len(), values.len())));
    }
    // Factors are found by name (a run's point, the ANOVA's effects): one name, one factor.
    for (j, name) in names.iter().enumerate() {
        if let Some(first) = names[..j].iter().position(|n| n == name) {
            return Err(err(format!(
                "orthogonal_design: factor `{name}` is named twice (factors {} and {}); give each factor its own name",
                first + 1,
                j + 1
            )));
        }
    }
    let q = values[0].len();
    if let Some(j) = values.iter().position(|v| v.len() != q) {
        return Err(err(format!(
            "orthogonal_design: `{}` has {} levels but `{}` has {q}; every factor needs the same number of levels \
             (mixed-level arrays such as L18 are not built)",
            names[j],
            values[j].len(),
            names[0]
        )));
    }
    if let Some((j, _)) = values.iter().enumerate().find(|(_, v)| v.iter().any(|x| !x.is_finite())) {
        return Err(err(format!("orthogonal_design: a level of `{}` is not a finite number", names[j])));
    }
    let cancelled = || host.control.is_cancelled();
    let array = OrthogonalArray::for_factors_until(q, names.len(), &cancelled)
        .map_err(design_err(host, "orthogonal_design"))?;
    array.check_until(&cancelled).map_err(design_err(host, "orthogonal_design (a bug in the construction)"))?;
    Ok(Design { array, factors: names, values })
}

fn pooling(opts: &Map) -> RhaiResult<Pooling> {
    match opts.get("pool") {
        None => Ok(Pooling::None),
        Some(v) if v.is_int() => {
            let k = v.as_int().unwrap_or(0);
            usize::try_from(k).map(Pooling::Weakest).map_err(|_| err(format!("anova: pool = {k}; give a count ≥ 0")))
        }
        Some(v) => match v.clone().try_cast::<Array>() {
            Some(a) => Ok(Pooling::Factors(names_of(&a, "anova: pool")?)),
            None => Err(err("anova: `pool` is a number of weakest effects or an array of factor names")),
        },
    }
}

fn fit_map(f: &Fit) -> Map {
    let mut m = Map::new();
    m.insert("form".into(), f.form.name().into());
    m.insert("a".into(), Dynamic::from_float(f.a));
    m.insert("b".into(), Dynamic::from_float(f.b));
    m.insert("r2".into(), Dynamic::from_float(f.r2));
    m.insert("formula".into(), f.formula().into());
    m
}

fn anova_rows(a: &AnovaResult) -> Array {
    a.anova
        .effects
        .iter()
        .map(|e| {
            let mut m = Map::new();
            m.insert("factor".into(), e.factor.clone().into());
            m.insert("ss".into(), Dynamic::from_float(e.ss));
            m.insert("dof".into(), Dynamic::from_int(e.dof as INT));
            m.insert("ms".into(), Dynamic::from_float(e.ms));
            m.insert("f".into(), Dynamic::from_float(e.f));
            m.insert("p".into(), Dynamic::from_float(e.p));
            m.insert("pooled".into(), e.pooled.into());
            m.insert("significance".into(), e.significance().into());
            m.insert("f_crit_05".into(), Dynamic::from_float(e.f_crit_05));
            m.insert("f_crit_01".into(), Dynamic::from_float(e.f_crit_01));
            m.insert(
                "level_means".into(),
                Dynamic::from_array(e.level_means.iter().map(|v| Dynamic::from_float(*v)).collect()),
            );
            Dynamic::from_map(m)
        })
        .collect()
}

fn anova_csv(a: &AnovaResult) -> RhaiResult<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let io = |e: csv::Error| err(format!("anova csv: {e}"));
    w.write_record(["source", "ss", "dof", "ms", "f", "p", "significance", "f_crit_05", "f_crit_01"]).map_err(io)?;
    for e in &a.anova.effects {
        let source = if e.pooled { format!("{} (pooled)", e.factor) } else { e.factor.clone() };
        w.write_record([
            source,
            e.ss.to_string(),
            e.dof.to_string(),
            e.ms.to_string(),
            e.f.to_string(),
            e.p.to_string(),
            e.significance().to_string(),
            e.f_crit_05.to_string(),
            e.f_crit_01.to_string(),
        ])
        .map_err(io)?;
    }
    let an = &a.anova;
    w.write_record(
        ["error".into(), an.ss_error.to_string(), an.dof_error.to_string(), an.ms_error().to_string()].iter().chain(&[
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
        ]),
    )
    .map_err(io)?;
    w.write_record(["total".into(), an.ss_total.to_string(), an.dof_total.to_string()].iter().chain(&[
        String::new(),
        String::new(),
        String::new(),
        String::new(),
        String::new(),
        String::new(),
    ]))
    .map_err(io)?;
    String::from_utf8(w.into_inner().map_err(|e| err(format!("anova csv: {e}")))?).map_err(|e| err(e.to_string()))
}

fn write_text(host: &Host, call: &str, name: &str, text: String) -> RhaiResult<Dynamic> {
    host.observe(call, || {
        let path = host.out_path(name)?;
        write_atomic(&path, text.as_bytes()).map_err(|e| err(format!("cannot write {}: {e}", path.display())))?;
        host.note_written([path.clone()]);
        Ok(Dynamic::from(path.display().to_string()))
    })
}

fn map_numbers(m: &Map, what: &str) -> RhaiResult<Vec<(String, f64)>> {
    m.iter()
        .map(|(k, v)| {
            super::arrays::number(v)
                .map(|x| (k.to_string(), x))
                .ok_or_else(|| err(format!("{what}: `{k}` is a {}, expected a number", v.type_name())))
        })
        .collect()
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<Design>("Design");
    engine.register_type_with_name::<AnovaResult>("Anova");
    engine.register_type_with_name::<Regression>("Regression");
    engine.register_type_with_name::<ResponseSurface>("Surface");
    engine.register_type_with_name::<ScriptRefinement>("Refinement");

    // Designs: the largest (L4096) take a second to build and prove, so a signal is heard.
    let h = host.clone();
    engine.register_fn("orthogonal_array", move |runs: INT, levels: INT| -> RhaiResult<Design> {
        if runs < 1 || levels < 2 {
            return Err(err(format!("orthogonal_array({runs}, {levels}): give runs ≥ 4 and levels ≥ 2, e.g. (25, 5)")));
        }
        let cancelled = || h.control.is_cancelled();
        let array = OrthogonalArray::with_runs_until(runs as usize, levels as usize, &cancelled)
            .map_err(design_err(&h, "orthogonal_array"))?;
        array.check_until(&cancelled).map_err(design_err(&h, "orthogonal_array (a bug in the construction)"))?;
        let q = levels as usize;
        let factors: Vec<String> = (1..=array.columns()).map(|c| format!("c{c}")).collect();
        let values = vec![(1..=q).map(|l| l as f64).collect(); factors.len()];
        Ok(Design { array, factors, values })
    });
    let h = host.clone();
    engine
        .register_fn("orthogonal_design", move |names: Array, levels: Array| -> RhaiResult<Design> {
            let names = names_of(&names, "orthogonal_design: names")?;
            let values = levels
                .iter()
                .enumerate()
                .map(|(j, v)| to_numbers(v, &format!("orthogonal_design: levels of factor {}", j + 1)))
                .collect::<RhaiResult<Vec<_>>>()?;
            design_of_values(&h, names, values)
        })
        .register_get("name", |d: &mut Design| d.array.name())
        .register_get("runs", |d: &mut Design| d.array.runs() as INT)
        .register_get("levels", |d: &mut Design| d.array.levels as INT)
        .register_get("factors", |d: &mut Design| -> Array { d.factors.iter().map(|f| f.clone().into()).collect() })
        .register_get("orthogonal", |d: &mut Design| d.array.check().is_ok())
        .register_fn("point", |d: &mut Design, run: INT| -> RhaiResult<Map> {
            let n = d.array.runs();
            usize::try_from(run).ok().filter(|&r| r < n).map(|r| d.point(r)).ok_or_else(|| {
                err(format!("design {}: run {run} does not exist; runs are 0 … {}", d.array.name(), n - 1))
            })
        })
        .register_fn("points", |d: &mut Design| -> Array {
            (0..d.array.runs()).map(|r| Dynamic::from_map(d.point(r))).collect()
        })
        .register_fn("column", |d: &mut Design, name: &str| -> RhaiResult<Field> {
            let j = d.factor(name)?;
            Ok(Field::new((0..d.array.runs()).map(|r| d.value(r, j)).collect()))
        })
        .register_fn("level", |d: &mut Design, name: &str| -> RhaiResult<Field> {
            let j = d.factor(name)?;
            Ok(Field::new(d.array.rows.iter().map(|r| f64::from(r[j]) + 1.0).collect()))
        })
        .register_fn("table", |d: &mut Design| Table(Rc::new(RefCell::new(d.table()))))
        .register_fn("to_string", |d: &mut Design| format!("{} over {}", d.array.name(), d.factors.join(", ")));
    let h = host.clone();
    engine.register_fn("save", move |d: &mut Design, name: &str| -> RhaiResult<Dynamic> {
        write_text(&h, "save_design", name, d.table().to_csv())
    });

    // ANOVA.
    let anova_fn = |d: &mut Design, y: Dynamic, opts: Map| -> RhaiResult<AnovaResult> {
        let y = to_numbers(&y, "anova: responses")?;
        check_keys(&opts, &["pool", "name"], "anova")?;
        let response = opts.get("name").map_or("response".to_string(), |v| v.to_string());
        let runs = d.array.runs();
        // Replicates: the responses of r copies of the design, one after the other.
        if y.is_empty() || !y.len().is_multiple_of(runs) {
            return Err(err(format!(
                "anova: {} responses for the {runs} runs of {}: give one per run (or per run of each replicate)",
                y.len(),
                d.array.name()
            )));
        }
        let one = d.levels_used();
        let design: Vec<Vec<u8>> = (0..y.len() / runs).flat_map(|_| one.iter().cloned()).collect();
        let a = anova::anova(&design, d.array.levels, &d.factors, &y, &pooling(&opts)?).map_err(cal("anova"))?;
        Ok(AnovaResult { anova: a, response, design: Rc::new(d.clone()) })
    };
    engine
        .register_fn("anova", anova_fn)
        .register_fn("anova", move |d: &mut Design, y: Dynamic| anova_fn(d, y, Map::new()))
        .register_get("rows", |a: &mut AnovaResult| anova_rows(a))
        .register_get("dof_error", |a: &mut AnovaResult| a.anova.dof_error as INT)
        .register_get("ss_error", |a: &mut AnovaResult| a.anova.ss_error)
        .register_get("ranking", |a: &mut AnovaResult| -> Array {
            a.anova.ranking().iter().filter(|e| !e.pooled).map(|e| e.factor.clone().into()).collect()
        })
        .register_fn("significant", |a: &mut AnovaResult, alpha: FLOAT| -> Array {
            a.anova.ranking().iter().filter(|e| !e.pooled && e.p <= alpha).map(|e| e.factor.clone().into()).collect()
        })
        .register_fn("to_string", |a: &mut AnovaResult| format!("ANOVA of {}\n{}", a.response, a.anova.to_text()));
    let h = host.clone();
    engine.register_fn("save", move |a: &mut AnovaResult, name: &str| -> RhaiResult<Dynamic> {
        write_text(&h, "save_anova", name, anova_csv(a)?)
    });
    let h = host.clone();
    engine.register_fn("plot_effects", move |a: &mut AnovaResult, name: &str| -> RhaiResult<Dynamic> {
        let mut c = LineChart::new(format!("Main effects on {}", a.response), "level", a.response.as_str());
        for e in &a.anova.effects {
            let x: Vec<f64> = (1..=e.level_means.len()).map(|l| l as f64).collect();
            c.add_series(e.factor.clone(), x, e.level_means.clone());
        }
        h.observe("plot_effects", || save_figure(&h, name, |p| c.save(p)))
    });
    let h = host.clone();
    engine.register_fn("plot_f", move |a: &mut AnovaResult, name: &str| -> RhaiResult<Dynamic> {
        let mut c = BarChart::new(format!("F of each factor on {} (pooled: none drawn)", a.response), "F");
        c.bars = a.anova.effects.iter().map(|e| (e.factor.clone(), if e.pooled { f64::NAN } else { e.f })).collect();
        if let Some(e) = a.anova.effects.iter().find(|e| !e.pooled) {
            c.thresholds = vec![
                (format!("F0.05({}, {})", e.dof, a.anova.dof_error), e.f_crit_05),
                (format!("F0.01({}, {})", e.dof, a.anova.dof_error), e.f_crit_01),
            ];
        }
        h.observe("plot_f", || save_figure(&h, name, |p| c.save(p)))
    });

    // Single-factor regressions.
    let regress = |x: Dynamic, y: Dynamic, form: Option<&str>| -> RhaiResult<Regression> {
        let x = to_numbers(&x, "regress: x")?;
        let y = to_numbers(&y, "regress: y")?;
        let fits = match form {
            None => regression::fit_all(&x, &y).map_err(cal("regress"))?,
            Some(f) => vec![regression::fit(Form::parse(f).map_err(cal("regress"))?, &x, &y).map_err(cal("regress"))?],
        };
        Ok(Regression { fits, x, y })
    };
    engine
        .register_fn("regress", move |x: Dynamic, y: Dynamic| regress(x, y, None))
        .register_fn("regress", move |x: Dynamic, y: Dynamic, form: &str| regress(x, y, Some(form)))
        .register_get("form", |r: &mut Regression| r.fits[0].form.name().to_string())
        .register_get("a", |r: &mut Regression| r.fits[0].a)
        .register_get("b", |r: &mut Regression| r.fits[0].b)
        .register_get("r2", |r: &mut Regression| r.fits[0].r2)
        .register_get("formula", |r: &mut Regression| r.fits[0].formula())
        .register_get("fits", |r: &mut Regression| -> Array {
            r.fits.iter().map(|f| Dynamic::from_map(fit_map(f))).collect()
        })
        .register_fn("predict", |r: &mut Regression, x: FLOAT| r.fits[0].predict(x))
        .register_fn("predict", |r: &mut Regression, x: Field| {
            Field::new(x.0.iter().map(|v| r.fits[0].predict(*v)).collect())
        })
        .register_fn("invert", |r: &mut Regression, y: FLOAT| r.fits[0].invert(y).map_err(cal("invert")))
        .register_fn("to_string", |r: &mut Regression| format!("{} (R² = {:.4})", r.fits[0].formula(), r.fits[0].r2));
    let h = host.clone();
    engine.register_fn(
        "plot",
        move |r: &mut Regression, name: &str, title: &str, x_label: &str, y_label: &str| -> RhaiResult<Dynamic> {
            let f = &r.fits[0];
            let mut order: Vec<usize> = (0..r.x.len()).collect();
            order.sort_by(|&a, &b| r.x[a].total_cmp(&r.x[b]));
            let (lo, hi) = (r.x[order[0]], r.x[*order.last().unwrap_or(&0)]);
            let xs: Vec<f64> = (0..=100).map(|i| lo + (hi - lo) * f64::from(i) / 100.0).collect();
            let mut c = LineChart::new(title, x_label, y_label);
            c.add_series(
                "runs",
                order.iter().map(|&i| r.x[i]).collect::<Vec<_>>(),
                order.iter().map(|&i| r.y[i]).collect::<Vec<_>>(),
            );
            c.add_series(
                format!("{}, R² = {:.4}", f.formula(), f.r2),
                xs.clone(),
                xs.iter().map(|&x| f.predict(x)).collect::<Vec<_>>(),
            );
            h.observe("plot_regression", || save_figure(&h, name, |p| c.save(p)))
        },
    );

    // Response surface and inversion.
    engine
        .register_fn("response_surface", |d: &mut Design, responses: Map| -> RhaiResult<ResponseSurface> {
            let x: Vec<Vec<f64>> =
                (0..d.array.runs()).map(|r| (0..d.factors.len()).map(|j| d.value(r, j)).collect()).collect();
            let mut names = Vec::new();
            let mut y = Vec::new();
            for (k, v) in &responses {
                names.push(k.to_string());
                y.push(to_numbers(v, &format!("response_surface: `{k}`"))?);
            }
            Surface::fit(&d.factors, &x, &names, &y)
                .map(|s| ResponseSurface(Rc::new(s)))
                .map_err(cal("response_surface"))
        })
        .register_get("r2", |s: &mut ResponseSurface| -> Map {
            s.0.responses.iter().zip(&s.0.r2).map(|(n, r)| (n.as_str().into(), Dynamic::from_float(*r))).collect()
        })
        .register_fn("predict", |s: &mut ResponseSurface, point: Map| -> RhaiResult<Map> {
            let p =
                s.0.factors
                    .iter()
                    .map(|f| {
                        point.get(f.as_str()).and_then(super::arrays::number).ok_or_else(|| {
                            err(format!(
                                "predict: the point needs a number for every factor ({}); `{f}` is missing",
                                s.0.factors.join(", ")
                            ))
                        })
                    })
                    .collect::<RhaiResult<Vec<f64>>>()?;
            Ok(s.0
                .responses
                .iter()
                .zip(s.0.predict(&p))
                .map(|(n, v)| (n.as_str().into(), Dynamic::from_float(v)))
                .collect())
        })
        .register_fn("invert", |s: &mut ResponseSurface, targets: Map, held: Map| -> RhaiResult<Map> {
            let t = map_numbers(&targets, "invert: targets")?;
            let h = map_numbers(&held, "invert: held factors")?;
            let inv = s.0.invert(&t, &h).map_err(cal("invert"))?;
            let names: Vec<String> = t.into_iter().map(|(n, _)| n).collect();
            Ok(inversion_map(&s.0, &names, &inv))
        })
        .register_fn(
            "refinement",
            |s: &mut ResponseSurface, targets: Map, held: Map| -> RhaiResult<ScriptRefinement> {
                let t = map_numbers(&targets, "refinement: targets")?;
                let h = map_numbers(&held, "refinement: held factors")?;
                let r = Refinement::new(&s.0, &t, &h).map_err(cal("refinement"))?;
                Ok(ScriptRefinement(Rc::new(RefCell::new(r))))
            },
        );
    engine
        .register_fn("propose", |r: &mut ScriptRefinement| -> RhaiResult<Map> {
            let mut r = r.0.borrow_mut();
            let inv = r.propose().map_err(cal("propose"))?;
            Ok(inversion_map(r.surface(), &r.target_names, &inv))
        })
        .register_fn("confirm", |r: &mut ScriptRefinement, point: Map, measured: Map| -> RhaiResult<Map> {
            let mut r = r.0.borrow_mut();
            let p = values_of(&point, &r.surface().factors, "confirm: the point")?;
            let y = values_of(&measured, &r.target_names, "confirm: the measured responses")?;
            let e = r.confirm(&p, &y).map_err(cal("confirm"))?;
            Ok(r.target_names.iter().zip(e).map(|(n, e)| (n.as_str().into(), Dynamic::from_float(e))).collect())
        })
        .register_fn("within", |r: &mut ScriptRefinement, tolerance: FLOAT| r.0.borrow().within(tolerance))
        .register_fn("to_string", |r: &mut ScriptRefinement| {
            let r = r.0.borrow();
            format!("refinement of {} by {} confirmation run(s)", r.target_names.join(", "), r.rounds.len())
        });

    // Generic Levenberg–Marquardt on a script function: f(params array) -> residuals array.
    engine.register_fn("least_squares", |ctx: NativeCallContext, f: FnPtr, x0: Array, opts: Map| -> RhaiResult<Map> {
        let x0 = to_numbers(&Dynamic::from_array(x0), "least_squares: start")?;
        check_keys(&opts, &["lower", "upper", "max_iterations"], "least_squares")?;
        let n = x0.len();
        let mut o = Options::unbounded(n);
        if let Some(v) = opts.get("lower") {
            o.lower = to_numbers(v, "least_squares: lower")?;
        }
        if let Some(v) = opts.get("upper") {
            o.upper = to_numbers(v, "least_squares: upper")?;
        }
        if let Some(v) = opts.get("max_iterations") {
            o.max_iterations = v
                .as_int()
                .ok()
                .and_then(|i| usize::try_from(i).ok())
                .ok_or_else(|| err("least_squares: max_iterations is a count"))?;
        }
        let script_error: RefCell<Option<Box<rhai::EvalAltResult>>> = RefCell::new(None);
        let sol = minimise(
            |p| {
                let args = Dynamic::from_array(p.iter().map(|v| Dynamic::from_float(*v)).collect());
                let r: Dynamic = f.call_within_context(&ctx, (args,)).map_err(|e| {
                    let msg = e.to_string();
                    *script_error.borrow_mut() = Some(e);
                    CalibrationError::new(msg)
                })?;
                to_numbers(&r, "least_squares: the function's residuals")
                    .map_err(|e| CalibrationError::new(e.to_string()))
            },
            &x0,
            &o,
        );
        if let Some(e) = script_error.into_inner() {
            return Err(e);
        }
        let sol = sol.map_err(cal("least_squares"))?;
        let mut m = Map::new();
        m.insert("x".into(), Dynamic::from_array(sol.x.iter().map(|v| Dynamic::from_float(*v)).collect()));
        m.insert("cost".into(), Dynamic::from_float(sol.cost));
        m.insert("iterations".into(), Dynamic::from_int(sol.iterations as INT));
        m.insert("converged".into(), sol.converged.into());
        Ok(m)
    });

    // Mohr–Coulomb from shear tests (`mohr_coulomb` is the triaxial one, from σ3 and σ1).
    engine.register_fn("shear_envelope", |sigma: Dynamic, tau: Dynamic| -> RhaiResult<Map> {
        let s = to_numbers(&sigma, "shear_envelope: normal stresses")?;
        let t = to_numbers(&tau, "shear_envelope: shear strengths")?;
        let e = mohr_coulomb::fit(&s, &t).map_err(cal("shear_envelope"))?;
        let mut m = Map::new();
        m.insert("c".into(), Dynamic::from_float(e.cohesion));
        m.insert("phi".into(), Dynamic::from_float(e.phi_deg));
        m.insert("r2".into(), Dynamic::from_float(e.r2));
        Ok(m)
    });
}
