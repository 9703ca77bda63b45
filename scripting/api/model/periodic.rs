//! Periodic boundaries (the `periodic` stage; MatDEM 5's `addPeriodBoundary`): along any of x,
//! y, z the model repeats, pairs meeting through their nearest image (engine/src/effects/periodic/).

use super::*;

/// `d.periodic(#{ x: [x0, x1], y: [y0, y1], z: [z0, z1] })`: any of the three.
fn periodic(d: &mut ModelHandle, axes: Map) -> RhaiResult<()> {
    let what = "d.periodic";
    let mut spans = [None; 3];
    for (k, v) in &axes {
        let a = match k.as_str() {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            other => return Err(raise(matdem_engine::Error::unknown("periodic axis", other, &["x", "y", "z"]))),
        };
        let n = to_numbers(v, what)?;
        let [lo, hi] = n[..] else {
            return Err(err(format!("{what}: `{k}` is [lo, hi] (m), the span that repeats along it")));
        };
        spans[a] = Some([lo, hi]);
    }
    d.model().periodic(spans).map_err(raise)
}

/// The periodic cell as a map of its axes' spans (an empty map without one).
fn periodic_cell(d: &mut ModelHandle) -> Map {
    let mut map = Map::new();
    if let Some(c) = d.model().settings.periodic {
        for (name, axis) in ["x", "y", "z"].iter().zip(c.axes) {
            if let Some([lo, hi]) = axis {
                map.insert((*name).into(), Dynamic::from_array(vec![lo.into(), hi.into()]));
            }
        }
    }
    map
}

pub(super) fn register(engine: &mut Engine) {
    engine
        .register_fn("periodic", periodic)
        .register_fn("periodic_cell", periodic_cell)
        .register_fn("unperiodic", |d: &mut ModelHandle| d.model().unperiodic());
}
