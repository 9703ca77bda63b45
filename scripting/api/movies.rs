//! Animations as scripts see them (MatDEM: `fs.movie2gif`): `d.movie_every(steps, field,
//! name[, options])` takes a picture of the particles coloured by `field` every `steps` steps
//! of the runs and balances that follow; `d.movie_end()` (or the end of the script) writes
//! them as `name.gif` in the output folder (see [`crate::movie`]).

use super::model::{install_observers, ModelHandle};
use super::{err, Host, RhaiResult};
use crate::movie::{MovieSettings, MovieState, DEFAULT_DELAY_CS, DEFAULT_MAX_FRAMES};
use rhai::{Dynamic, Engine, Map, INT};
use std::rc::Rc;

/// The keys of `movie_every`'s options.
const OPTIONS: &[&str] = &["slice", "frames_png", "max_frames", "delay", "range"];

/// A movie's name becomes file names: letters, digits, `_`, `-` and `.`; `.gif` may be given.
fn movie_name(name: &str) -> RhaiResult<String> {
    let stem = name.strip_suffix(".gif").or_else(|| name.strip_suffix(".GIF")).unwrap_or(name);
    let ok = !stem.is_empty()
        && !stem.starts_with('.')
        && stem.chars().all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
    if ok {
        Ok(stem.to_string())
    } else {
        Err(err(format!(
            "movie_every: the name `{name}` must be letters, digits, `_`, `-` or `.` (not starting with `.`), e.g. \
             \"compression\"; the movie is written as NAME.gif in the run's output folder"
        )))
    }
}

fn number(v: &Dynamic) -> Option<f64> {
    v.as_float().ok().or_else(|| v.as_int().ok().map(|i| i as f64))
}

/// The settings of `movie_every`, every value checked; `stem` is the checked name.
fn settings(
    host: &Host,
    d: &ModelHandle,
    steps: INT,
    field: &str,
    stem: &str,
    opts: &Map,
) -> RhaiResult<MovieSettings> {
    let fail = |msg: String| err(format!("movie_every: {msg}"));
    if steps <= 0 {
        return Err(fail(format!(
            "steps must be ≥ 1 (a frame every so many steps), got {steps}; to end a movie call d.movie_end()"
        )));
    }
    let (label, model) = {
        let mut data = d.data();
        // Checks the field now (unknown, or a field that is off), not at the first frame.
        let loads = matches!(field, "contact_load" | "force").then(|| data.sim.contact_loads());
        let (_, label) =
            crate::picture_fields::field_values(&data.sim.model, field, |_| loads.unwrap_or_default()).map_err(fail)?;
        (label, data.name.clone())
    };
    let mut s = MovieSettings {
        every: steps as u64,
        field: field.to_string(),
        label,
        model,
        slice: None,
        frames_png: false,
        max_frames: DEFAULT_MAX_FRAMES,
        delay_cs: DEFAULT_DELAY_CS,
        range: None,
        gif: host.out_path(&format!("{stem}.gif"))?,
        spool: host.out_path(&format!(".{stem}.gif.frames"))?,
        frames_dir: host.out_path(&format!("{stem}_frames"))?,
    };
    for (key, v) in opts {
        match key.as_str() {
            "slice" => match number(v) {
                Some(w) if w.is_finite() && w > 0.0 => s.slice = Some(w),
                _ => {
                    return Err(fail(format!(
                        "slice is the half-width of the slice about the mid-plane in y, a number > 0 (m), got {v}"
                    )))
                }
            },
            "frames_png" => {
                s.frames_png = v.as_bool().map_err(|_| fail(format!("frames_png must be true or false, got {v}")))?;
            }
            "max_frames" => match v.as_int() {
                Ok(n) if n >= 1 => s.max_frames = n as u64,
                _ => return Err(fail(format!("max_frames must be an integer ≥ 1, got {v}"))),
            },
            "delay" => match number(v) {
                Some(t) if t.is_finite() && t > 0.0 && t <= 655.35 => {
                    s.delay_cs = (t * 100.0).round().max(1.0) as u16;
                }
                _ => {
                    return Err(fail(format!(
                        "delay is the time each frame is shown, a number of seconds > 0 and ≤ 655.35, got {v}"
                    )))
                }
            },
            "range" => {
                let pair = v.clone().try_cast::<rhai::Array>().map(|a| a.iter().map(number).collect::<Vec<_>>());
                match pair.as_deref() {
                    Some([Some(lo), Some(hi)]) if lo.is_finite() && hi.is_finite() && lo < hi => {
                        s.range = Some((*lo, *hi));
                    }
                    _ => {
                        return Err(fail(format!(
                            "range is the colour scale [lo, hi], two finite numbers with lo < hi, got {v}"
                        )))
                    }
                }
            }
            other => {
                return Err(fail(format!("unknown option `{other}`; the options are {}", OPTIONS.join(", "))));
            }
        }
    }
    Ok(s)
}

/// `d.movie_every(...)`: ends the model's movie, if any, and starts this one.
fn movie_every(host: &Host, d: &ModelHandle, steps: INT, field: &str, name: &str, opts: &Map) -> RhaiResult<()> {
    let stem = movie_name(name)?;
    let s = settings(host, d, steps, field, &stem, opts)?;
    // Two movies of one name would share their files.
    for other in host.models.borrow().iter().filter_map(|w| w.upgrade()) {
        if Rc::ptr_eq(&other, &d.0) {
            continue;
        }
        let other = other.borrow();
        let movie = other.movie.borrow();
        if movie.state.settings.as_ref().is_some_and(|o| o.gif == s.gif) {
            return Err(err(format!(
                "movie_every: model `{}` is already taking the movie `{stem}`; give this one another name, or end that \
                 one first with its movie_end()",
                other.name
            )));
        }
    }
    end(host, d)?;
    let mut data = d.data();
    data.movie.borrow_mut().state = MovieState { settings: Some(s), ..MovieState::default() };
    install_observers(&mut data);
    Ok(())
}

/// Ends the model's movie, writing its GIF; returns the files written.
fn end(host: &Host, d: &ModelHandle) -> RhaiResult<Vec<std::path::PathBuf>> {
    let mut data = d.data();
    let written = data.movie.borrow_mut().finish(false).map_err(err)?;
    install_observers(&mut data);
    host.note_written(written.iter().cloned());
    Ok(written)
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    // `d.movie_every(steps, field, "name")`: a picture coloured by `field` every `steps`
    // steps of the runs that follow, written as `name.gif` when the movie ends.
    let h = host.clone();
    engine.register_fn("movie_every", move |d: &mut ModelHandle, steps: INT, field: &str, name: &str| {
        movie_every(&h, d, steps, field, name, &Map::new())
    });
    // `d.movie_every(steps, field, "name", #{ slice, frames_png, max_frames, delay, range })`.
    let h = host.clone();
    engine.register_fn("movie_every", move |d: &mut ModelHandle, steps: INT, field: &str, name: &str, opts: Map| {
        movie_every(&h, d, steps, field, name, &opts)
    });
    // `d.movie_end()`: writes the model's movie; returns the files written.
    engine.register_fn("movie_end", move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
        // Journaled: a resumed run does not end (and so rewrite) a movie finished before the
        // interruption; its replay took no frames anyway.
        host.observe("movie_end", || {
            let written = end(&host, d)?;
            Ok(Dynamic::from_array(written.iter().map(|p| Dynamic::from(p.display().to_string())).collect()))
        })
    });
}

impl Host {
    /// Ends the movie of every model still alive (the end of a run: finished, failed or
    /// stopped), writing its GIF; `keep_spools` keeps their frames for a resume. Returns the
    /// errors, in words.
    pub fn finish_movies(&self, keep_spools: bool) -> Vec<String> {
        let mut errors = Vec::new();
        for model in self.models.borrow().iter().filter_map(|w| w.upgrade()) {
            let Ok(data) = model.try_borrow() else { continue };
            let result = data.movie.borrow_mut().finish(keep_spools);
            match result {
                Ok(written) => self.note_written(written),
                Err(e) => errors.push(e),
            }
        }
        errors
    }
}
