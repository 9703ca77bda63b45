//! 2D models (MatDEM's `sampleL = 0`): a model in the x–z plane, one layer of elements, every
//! one held in y and in spin about x and z (engine/src/planar/).

use super::*;

/// `d.make_2d()` / `d.make_2d(#{ thickness })`.
fn make_2d(d: &mut ModelHandle, opts: Map) -> RhaiResult<()> {
    let mut thickness = None;
    for (k, v) in &opts {
        match k.as_str() {
            "thickness" => {
                let t = number(v).ok_or_else(|| {
                    err(format!("d.make_2d: `thickness` must be a number (m), got {}", v.type_name()))
                })?;
                thickness = Some(t);
            }
            other => return Err(raise(matdem_engine::Error::unknown("2D setting", other, &["thickness"]))),
        }
    }
    d.model().make_planar(thickness).map_err(raise)
}

pub(super) fn register(engine: &mut Engine) {
    engine
        .register_fn("make_2d", make_2d)
        .register_fn("make_2d", |d: &mut ModelHandle| make_2d(d, Map::new()))
        .register_fn("dimension", |d: &mut ModelHandle| -> INT {
            if d.model().planar().is_some() {
                2
            } else {
                3
            }
        })
        .register_fn("thickness", |d: &mut ModelHandle| -> Dynamic {
            d.model().planar().map_or(Dynamic::UNIT, |p| p.thickness.into())
        });
}
