//! Periodic boundaries (the `periodic` stage; MatDEM 5's `addPeriodBoundary`): along any of x,
//! y, z the model repeats, pairs meeting through their nearest image (engine/src/effects/periodic/).

use super::*;

/// `d.periodic(#{ x: [x0, x1], y: [y0, y1], z: [z0, z1], shear_rate })`: any of the three axes,
/// and Lees–Edwards shear with x and z.
fn periodic(d: &mut ModelHandle, axes: Map) -> RhaiResult<()> {
    let what = "d.periodic";
    let mut spans = [None; 3];
    let mut shear = None;
    for (k, v) in &axes {
        let a = match k.as_str() {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            "shear_rate" => {
                shear = Some(number(v).ok_or_else(|| err(format!("{what}: `shear_rate` is γ̇ (1/s), a number")))?);
                continue;
            }
            other => {
                return Err(raise(matdem_engine::Error::unknown(
                    "periodic axis",
                    other,
                    &["x", "y", "z", "shear_rate"],
                )))
            }
        };
        let n = to_numbers(v, what)?;
        let [lo, hi] = n[..] else {
            return Err(err(format!("{what}: `{k}` is [lo, hi] (m), the span that repeats along it")));
        };
        spans[a] = Some([lo, hi]);
    }
    let mut m = d.model();
    m.periodic(spans).map_err(raise)?;
    match shear {
        Some(rate) => m.lees_edwards(rate).map_err(raise),
        None => Ok(()),
    }
}

/// The periodic cell as a map of its axes' spans (an empty map without one).
fn periodic_cell(d: &mut ModelHandle) -> Map {
    let mut map = Map::new();
    if let Some(c) = d.model().effects.periodic.cell {
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
        .register_fn("lees_edwards", |d: &mut ModelHandle, rate: Dynamic| -> RhaiResult<()> {
            let rate = number(&rate).ok_or_else(|| err("d.lees_edwards: the shear rate γ̇ (1/s) is a number"))?;
            d.model().lees_edwards(rate).map_err(raise)
        })
        .register_fn("unperiodic", |d: &mut ModelHandle| d.model().unperiodic());
}
