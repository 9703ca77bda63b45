//! Plots and particle pictures (MatDEM: `d.show('aZ')`, `fs.plot`), rendered headlessly to
//! SVG and PNG under the run's output folder.

use super::arrays::{to_numbers, Field};
use super::model::ModelHandle;
use super::table::Table;
use super::{err, Host, RhaiResult};
use crate::memory::Charge;
use crate::picture_fields::{field_values, picture_title, pictured};
use crate::plot::{LineChart, ParticlePicture};
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

/// The values of a named per-particle field for pictures (contact loads over rows brought
/// up to date).
fn particle_field(d: &ModelHandle, name: &str) -> RhaiResult<(Vec<f64>, String)> {
    let mut data = d.data();
    let loads = matches!(name, "contact_load" | "force").then(|| data.sim.contact_loads());
    field_values(&data.sim.model, name, |_| loads.unwrap_or_default()).map_err(|e| err(format!("show: {e}")))
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
