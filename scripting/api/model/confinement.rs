//! The triaxial cell's confining pressure (the `confining_pressure` stage): a pressure on the side
//! of a cylindrical sample between two platens, on the grains the membrane touches
//! (effects/confining_pressure/), and the membrane's state as a triaxial test reads it.

use super::*;
use matdem_engine::effects::confining_pressure::{ConfineRequest, Membrane};

const KEYS: [&str; 6] = ["pressure", "bottom", "top", "axis", "bands", "sectors"];

/// `d.confine(#{ pressure, bottom, top, axis, bands, sectors })`.
fn confine(d: &mut ModelHandle, opts: Map) -> RhaiResult<()> {
    let what = "d.confine";
    let mut req = ConfineRequest {
        pressure: f64::NAN,
        bottom: "bottom".into(),
        top: "top_platen".into(),
        axis: [0.0, 0.0],
        bands: None,
        sectors: None,
    };
    for (k, v) in &opts {
        let x = || number(v).ok_or_else(|| err(format!("{what}: `{k}` must be a number, got {}", v.type_name())));
        let cells = || -> RhaiResult<Option<u32>> {
            let n = x()?;
            if n.fract() == 0.0 && (1.0..=f64::from(u32::MAX)).contains(&n) {
                Ok(Some(n as u32))
            } else {
                Err(err(format!("{what}: `{k}` must be a whole number ≥ 1, got {n}")))
            }
        };
        match k.as_str() {
            "pressure" => req.pressure = x()?,
            "bottom" => req.bottom = v.to_string(),
            "top" => req.top = v.to_string(),
            "axis" => {
                let xy: Vec<f64> =
                    v.clone().into_array().ok().map(|a| a.iter().filter_map(number).collect()).unwrap_or_default();
                let [x, y] = xy[..] else {
                    return Err(err(format!("{what}: `axis` is [x, y] (m), the sample's vertical axis")));
                };
                req.axis = [x, y];
            }
            "bands" => req.bands = cells()?,
            "sectors" => req.sectors = cells()?,
            other => return Err(raise(matdem_engine::Error::unknown("confinement setting", other, &KEYS))),
        }
    }
    if req.pressure.is_nan() && !opts.contains_key("pressure") {
        return Err(err(format!("{what}: give #{{ pressure: σ3 (Pa) }} (and bottom, top: the platens' names)")));
    }
    d.model().confine(req).map_err(raise)
}

fn membrane_map(m: Option<Membrane>) -> Dynamic {
    let Some(m) = m else { return Dynamic::UNIT };
    let mut map = Map::new();
    for (k, v) in [
        ("pressure", m.pressure),
        ("radius", m.radius),
        ("height", m.height),
        ("area", m.area),
        ("load", m.load),
        ("stress", m.stress),
        ("volume", m.volume),
    ] {
        map.insert(k.into(), v.into());
    }
    map.insert("cells".into(), (m.cells as INT).into());
    map.insert("touched".into(), (m.touched as INT).into());
    map.insert("covered".into(), (m.covered as INT).into());
    map.into()
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_fn("confine", confine)
        .register_fn("unconfine", |d: &mut ModelHandle| d.model().unconfine())
        .register_fn("membrane", observed!(host, "membrane", |d| membrane_map(d.model().membrane())));
}
