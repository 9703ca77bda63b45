//! Plots and particle pictures (MatDEM: `d.show('aZ')`, `fs.plot`), rendered headlessly to
//! SVG and PNG under the run's output folder.

use super::field::{to_numbers, Field};
use super::model::ModelHandle;
use super::table::Table;
use super::{err, Host, RhaiResult};
use crate::memory::Charge;
use crate::plot::{LineChart, ParticlePicture};
use matdem_engine::Model;
use rhai::{Dynamic, Engine, FLOAT};
use std::cell::RefCell;
use std::rc::Rc;

/// A line chart being assembled by a script, its points counted in the memory budget.
#[derive(Clone)]
pub struct Chart(pub Rc<RefCell<LineChart>>, Rc<RefCell<Charge>>);

impl Chart {
    /// A chart of none or one series (`chart(...)`, `plot(...)`).
    fn new(chart: LineChart) -> Chart {
        let held = Chart(Rc::new(RefCell::new(chart)), Rc::default());
        held.count_last_series();
        held
    }

    /// Counts the last series added (its numbers are copies the chart keeps).
    fn count_last_series(&self) {
        if let Some(s) = self.0.borrow().series.last() {
            let values = s.x.len() + s.y.len() + s.x_err.len() + s.y_err.len();
            self.1.borrow_mut().add(8 * values as u64);
        }
    }
}

/// Renders and writes a figure. Callers wrap it, and whatever reads the model for it, in
/// one `observe`, so a resumed run neither redraws nor rewrites the figures finished before
/// its interruption.
pub(crate) fn save_figure(
    host: &Host,
    name: &str,
    save: impl FnOnce(&std::path::Path) -> Result<Vec<std::path::PathBuf>, crate::plot::PlotError>,
) -> RhaiResult<Dynamic> {
    let path = host.out_path(name)?;
    let written = save(&path).map_err(|e| err(format!("cannot save `{name}`: {e}")))?;
    host.note_written(written.iter().cloned());
    Ok(Dynamic::from_array(written.iter().map(|p| Dynamic::from(p.display().to_string())).collect()))
}

/// A chart leaves out the points it cannot draw (NaN — a table's missing value — ±inf,
/// beyond ±1e300); it says so once per chart file and series, naming the first point.
fn warn_gaps(host: &Host, chart: &LineChart, name: &str) {
    for g in chart.gaps() {
        host.warn(
            &format!("chart gap {name} {}", g.series),
            format!(
                "chart `{name}`: series `{}` has {} point(s) that cannot be drawn (NaN, ±inf or beyond ±1e300), \
                 left out of its line; the first is index {} (x = {}, y = {}). To plot only the drawable points: \
                 `let m = x.is_finite() & y.is_finite(); c.series(name, x.select(m), y.select(m))`",
                g.series, g.count, g.first, g.x, g.y
            ),
        );
    }
}

/// The per-particle fields a picture (`show`) or a movie (`movie_every`) can be coloured by.
pub(crate) const PICTURE_FIELDS: &[&str] = &[
    "x",
    "y",
    "z",
    "r",
    "dx",
    "dy",
    "dz",
    "displacement",
    "vx",
    "vy",
    "vz",
    "speed",
    "fx",
    "fy",
    "fz",
    "mass",
    "material",
    "size_class",
    "contact_load",
    "temperature",
    "water",
];

/// The values of the per-particle field `name` of `m` (one of [`PICTURE_FIELDS`]) and its
/// label with units; `contact_loads` gives the contact loads when they are asked for. The
/// error says what to do.
pub(crate) fn field_values(
    m: &Model,
    name: &str,
    contact_loads: impl FnOnce(&Model) -> Vec<f64>,
) -> Result<(Vec<f64>, String), String> {
    let n = m.len();
    let p = &m.particles;
    let each = |f: &dyn Fn(usize) -> f64| (0..n).map(f).collect::<Vec<f64>>();
    let v: Vec<f64> = match name {
        "x" => each(&|i| p.pos[i].x),
        "y" => each(&|i| p.pos[i].y),
        "z" => each(&|i| p.pos[i].z),
        "r" | "radius" => p.radius.clone(),
        "dx" => each(&|i| p.pos[i].x - p.origin[i].x),
        "dy" => each(&|i| p.pos[i].y - p.origin[i].y),
        "dz" => each(&|i| p.pos[i].z - p.origin[i].z),
        "displacement" => each(&|i| (p.pos[i] - p.origin[i]).norm()),
        "vx" => each(&|i| p.vel[i].x),
        "vy" => each(&|i| p.vel[i].y),
        "vz" => each(&|i| p.vel[i].z),
        "speed" => each(&|i| p.vel[i].norm()),
        "fx" => each(&|i| p.force[i].x),
        "fy" => each(&|i| p.force[i].y),
        "fz" => each(&|i| p.force[i].z),
        "mass" => p.mass.clone(),
        "material" => p.material.iter().map(|&k| k as f64).collect(),
        "size_class" => {
            let mut v = vec![0.0; n];
            for k in 1.. {
                match m.groups.get(&format!("class{k}")) {
                    Ok(ids) => ids.iter().for_each(|&i| v[i as usize] = k as f64),
                    Err(_) => break,
                }
            }
            v
        }
        "contact_load" | "force" => contact_loads(m),
        "temperature" => {
            let t = &p.thermal.temperature;
            if t.len() != n {
                return Err("no temperature field: call d.enable(\"heat\") first (docs/fields.md)".into());
            }
            t.clone()
        }
        "water" => {
            let w = &p.moisture.water;
            if w.len() != n {
                return Err("no water field: call d.enable(\"moisture\") first (docs/fields.md)".into());
            }
            w.clone()
        }
        other => return Err(matdem_engine::Error::unknown("particle field", other, PICTURE_FIELDS).to_string()),
    };
    let label = match name {
        "displacement" | "dx" | "dy" | "dz" | "x" | "y" | "z" | "r" | "radius" => format!("{name} [m]"),
        "vx" | "vy" | "vz" | "speed" => format!("{name} [m/s]"),
        "fx" | "fy" | "fz" => format!("{name} [N]"),
        "mass" => "mass [kg]".to_string(),
        "contact_load" | "force" => "contact load [N]".to_string(),
        "temperature" => "temperature [K]".to_string(),
        "water" => "water content [kg/kg]".to_string(),
        other => other.to_string(),
    };
    Ok((v, label))
}

/// The values of a named per-particle field for pictures (contact loads over rows brought
/// up to date).
fn particle_field(d: &ModelHandle, name: &str) -> RhaiResult<(Vec<f64>, String)> {
    let mut data = d.data();
    let loads = matches!(name, "contact_load" | "force").then(|| data.sim.contact_loads());
    field_values(&data.sim.model, name, |_| loads.unwrap_or_default()).map_err(|e| err(format!("show: {e}")))
}

/// The particles a picture of `m` draws: those not killed and, with `slice`, within that
/// distance of the model's mid-plane in y, so the inside of a sample shows.
pub(crate) fn pictured(m: &Model, slice: Option<f64>) -> Vec<usize> {
    let p = &m.particles;
    let n = p.len().max(1) as f64;
    let y_mid = p.pos.iter().map(|x| x.y).sum::<f64>() / n;
    // Killed elements (d.kill) are out of the model: not drawn.
    (0..p.len()).filter(|&i| !m.is_killed(i) && slice.is_none_or(|w| (p.pos[i].y - y_mid).abs() <= w)).collect()
}

/// A picture's title: the model, the field and the slice, if any.
pub(crate) fn picture_title(model: &str, label: &str, slice: Option<f64>) -> String {
    match slice {
        Some(w) => format!("{model} — {label} (slice |y − ȳ| ≤ {w:.2e} m)"),
        None => format!("{model} — {label}"),
    }
}

/// A side view (x–z) of the particles; with `slice`, only those within that distance of
/// the model's mid-plane in y, so the inside of a sample shows.
fn picture(d: &ModelHandle, values: Vec<f64>, label: String, slice: Option<f64>) -> ParticlePicture {
    let data = d.data();
    let m = &data.sim.model;
    let p = &m.particles;
    let keep = pictured(m, slice);
    ParticlePicture {
        title: picture_title(&data.name, &label, slice),
        field: label,
        x_label: "x [m]".into(),
        y_label: "z [m]".into(),
        x: keep.iter().map(|&i| p.pos[i].x).collect(),
        y: keep.iter().map(|&i| p.pos[i].z).collect(),
        r: keep.iter().map(|&i| p.radius[i]).collect(),
        value: keep.iter().map(|&i| values[i]).collect(),
    }
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<Chart>("Chart");
    engine
        .register_fn("chart", |title: &str, x_label: &str, y_label: &str| {
            Chart::new(LineChart::new(title, x_label, y_label))
        })
        .register_fn("series", |c: &mut Chart, name: &str, x: Dynamic, y: Dynamic| -> RhaiResult<Chart> {
            let (x, y) = (to_numbers(&x, "series x")?, to_numbers(&y, "series y")?);
            if x.len() != y.len() {
                return Err(err(format!("series `{name}`: x has {} values but y has {}", x.len(), y.len())));
            }
            c.0.borrow_mut().add_series(name, x, y);
            c.count_last_series();
            Ok(c.clone())
        })
        .register_fn(
            "series",
            |c: &mut Chart, name: &str, x: Dynamic, y: Dynamic, bars: rhai::Map| -> RhaiResult<Chart> {
                let (x, y) = (to_numbers(&x, "series x")?, to_numbers(&y, "series y")?);
                if x.len() != y.len() {
                    return Err(err(format!("series `{name}`: x has {} values but y has {}", x.len(), y.len())));
                }
                let mut errs = [Vec::new(), Vec::new()];
                for (key, v) in &bars {
                    let k = match key.as_str() {
                        "x_err" => 0,
                        "y_err" => 1,
                        other => {
                            return Err(err(format!(
                                "series `{name}`: unknown key `{other}`: error bars are given as #{{ x_err: [...], \
                                 y_err: [...] }} (half-lengths, one per point)"
                            )))
                        }
                    };
                    let e = to_numbers(v, key.as_str())?;
                    if e.len() != x.len() {
                        return Err(err(format!(
                            "series `{name}`: {key} has {} values but the series has {} points",
                            e.len(),
                            x.len()
                        )));
                    }
                    errs[k] = e;
                }
                let [x_err, y_err] = errs;
                c.0.borrow_mut().add_series_with_errors(name, x, y, x_err, y_err);
                c.count_last_series();
                Ok(c.clone())
            },
        )
        .register_fn("plot", |t: Table, x: &str, y: &str| -> RhaiResult<Chart> {
            let data = t.0.borrow();
            let mut c = LineChart::new(format!("{y} vs {x}"), x, y);
            c.add_series(y, data.column(x)?.to_vec(), data.column(y)?.to_vec());
            Ok(Chart::new(c))
        })
        .register_fn("plot", |x: Field, y: Field| -> RhaiResult<Chart> {
            let mut c = LineChart::new("", "x", "y");
            if x.0.len() != y.0.len() {
                return Err(err(format!("plot: x has {} values but y has {}", x.0.len(), y.0.len())));
            }
            c.add_series("y", x.0.to_vec(), y.0.to_vec());
            Ok(Chart::new(c))
        });
    let h = host.clone();
    engine.register_fn("save", move |c: &mut Chart, name: &str| {
        let chart = c.0.borrow();
        h.observe("save_chart", || {
            warn_gaps(&h, &chart, name);
            let saved = save_figure(&h, name, |p| chart.save_until(p, &|| h.control.is_cancelled()));
            if h.control.is_cancelled() {
                return Err(super::cancelled(&h));
            }
            saved
        })
    });
    let h = host.clone();
    engine.register_fn("show", move |d: &mut ModelHandle, field: &str, name: &str| {
        h.observe("show", || {
            let (values, label) = particle_field(d, field)?;
            let pic = picture(d, values, label, None);
            save_figure(&h, name, |p| pic.save(p))
        })
    });
    let h = host.clone();
    engine.register_fn("show", move |d: &mut ModelHandle, field: &str, name: &str, slice: FLOAT| {
        if !(slice.is_finite() && slice > 0.0) {
            return Err(err(format!("show: the slice half-width must be > 0 m, got {slice}")));
        }
        h.observe("show", || {
            let (values, label) = particle_field(d, field)?;
            let pic = picture(d, values, label, Some(slice));
            save_figure(&h, name, |p| pic.save(p))
        })
    });
    let h = host.clone();
    engine.register_fn("show", move |d: &mut ModelHandle, values: Field, label: &str, name: &str| {
        show_values(&h, d, values, label, name, None)
    });
    let h = host;
    engine.register_fn("show", move |d: &mut ModelHandle, values: Field, label: &str, name: &str, slice: FLOAT| {
        show_values(&h, d, values, label, name, Some(slice))
    });
}

/// `d.show(values, label, name[, slice])`: a picture of any per-element field, optionally a
/// slice through the mid-plane (the inside of a 3-D block, e.g. a pile on its axis).
fn show_values(
    h: &Rc<Host>,
    d: &mut ModelHandle,
    values: Field,
    label: &str,
    name: &str,
    slice: Option<FLOAT>,
) -> RhaiResult<Dynamic> {
    if values.0.len() != d.data().sim.model.len() {
        return Err(err(format!("show: {} values for {} particles", values.0.len(), d.data().sim.model.len())));
    }
    if let Some(w) = slice.filter(|w| !(w.is_finite() && *w > 0.0)) {
        return Err(err(format!("show: the slice half-width must be > 0 m, got {w}")));
    }
    h.observe("show", || {
        let pic = picture(d, values.0.to_vec(), label.to_string(), slice);
        save_figure(h, name, |p| pic.save(p))
    })
}
