//! The moisture field as scripts see it (paper 003 §3.3, issue 15 item 3): `d.enable("moisture")`
//! switches the `moisture` stage on; `d.water` is a writable whole-array field of water
//! contents; `d.moisture(material or group, #{ diffusivity })` sets how fast water moves
//! between elements; groups are held at a water content, sealed, or dried by evaporation;
//! `d.water_radius_table` and `d.water_strength_table` couple the water content to the
//! radius (drying shrinkage) and to bond strength. Each name is documented in
//! scripting/api/docs.rs; the physics in docs/fields.md.

use super::*;
use matdem_engine::effects::moisture::WaterMode;

/// A count ≥ 1 from a script integer.
fn count(name: &str, v: INT) -> RhaiResult<u32> {
    u32::try_from(v).ok().filter(|&c| c >= 1).ok_or_else(|| err(format!("{name} must be an integer ≥ 1, got {v}")))
}

/// A table `[[water, value], …]` (or `()` for none).
fn table(v: &Dynamic, what: &str) -> RhaiResult<Option<Vec<(f64, f64)>>> {
    if v.is_unit() {
        return Ok(None);
    }
    let bad =
        || err(format!("{what}: expected [[water content, value], …] (water contents increasing), or () for none"));
    let rows = v.clone().try_cast::<Array>().ok_or_else(bad)?;
    rows.iter()
        .map(|row| {
            let p = row.clone().try_cast::<Array>().ok_or_else(bad)?;
            match (p.first().and_then(number), p.get(1).and_then(number), p.len()) {
                (Some(w), Some(x), 2) => Ok((w, x)),
                _ => Err(bad()),
            }
        })
        .collect::<RhaiResult<Vec<_>>>()
        .map(Some)
}

fn table_value(t: &Option<matdem_engine::effects::moisture::physics::Table>) -> Dynamic {
    match t {
        Some(t) => Dynamic::from_array(
            t.points
                .iter()
                .map(|&(w, v)| Dynamic::from_array(vec![Dynamic::from_float(w), Dynamic::from_float(v)]))
                .collect(),
        ),
        None => Dynamic::UNIT,
    }
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_get(
            "water",
            observed!(host, "water", |d| {
                let m = d.model();
                let w = &m.effects.moisture.lanes.water;
                if !m.effects.moisture.settings.enabled || w.len() != m.len() {
                    return Err(err("d.water: moisture is off; call d.enable(\"moisture\") first"));
                }
                Field::new(w.clone())
            }),
        )
        .register_set("water", |d: &mut ModelHandle, value: Dynamic| -> RhaiResult<()> {
            let mut m = d.model();
            let n = m.len();
            let w = if let Some(x) = number(&value) {
                vec![x; n]
            } else if let Some(f) = value.clone().try_cast::<Field>() {
                f.0.to_vec()
            } else {
                return Err(err(format!("d.water = …: expected a number or a Field, got {}", value.type_name())));
            };
            m.set_water(&w).map_err(|e| err(format!("d.water = …: {e}; nothing was changed")))
        })
        .register_get("total_water", observed!(host, "total_water", |d| d.model().total_water()))
        .register_fn("moisture", |d: &mut ModelHandle, name: &str, props: Map| -> RhaiResult<()> {
            let call = format!("d.moisture(\"{name}\", …)");
            let mut diffusivity = None;
            for (k, v) in &props {
                match k.as_str() {
                    "diffusivity" | "alpha_w" => {
                        diffusivity = Some(number(v).ok_or_else(|| {
                            err(format!("{call}: `{k}` must be a number (kg/(m²·s)), got {}", v.type_name()))
                        })?)
                    }
                    other => {
                        return Err(raise(matdem_engine::Error::unknown("moisture property", other, &["diffusivity"])))
                    }
                }
            }
            let Some(a) = diffusivity else { return Err(err(format!("{call}: give #{{ diffusivity: … }}"))) };
            let mut m = d.model();
            if m.material_index(name).is_ok() {
                return m.set_moisture_material(name, a).map_err(raise);
            }
            if m.groups.get(name).is_ok() {
                return m.set_moisture_group(name, a).map_err(raise);
            }
            Err(err(format!("{call}: `{name}` is neither a material nor a group of this model")))
        })
        .register_fn("fix_water", |d: &mut ModelHandle, group: &str| {
            d.model().set_water_mode(group, WaterMode::Fixed(None)).map_err(raise)
        })
        .register_fn("fix_water", |d: &mut ModelHandle, group: &str, w: FLOAT| {
            d.model().set_water_mode(group, WaterMode::Fixed(Some(w))).map_err(raise)
        })
        .register_fn("seal", |d: &mut ModelHandle, group: &str| {
            d.model().set_water_mode(group, WaterMode::Sealed).map_err(raise)
        })
        .register_fn("free_water", |d: &mut ModelHandle, group: &str| {
            d.model().set_water_mode(group, WaterMode::Free).map_err(raise)
        })
        .register_fn("evaporate", |d: &mut ModelHandle, group: &str, props: Map| -> RhaiResult<()> {
            let call = format!("d.evaporate(\"{group}\", …)");
            let (mut transfer, mut ambient) = (None, 0.0);
            for (k, v) in &props {
                let x =
                    number(v).ok_or_else(|| err(format!("{call}: `{k}` must be a number, got {}", v.type_name())))?;
                match k.as_str() {
                    "transfer" | "coefficient" => transfer = Some(x),
                    "ambient" => ambient = x,
                    other => {
                        return Err(raise(matdem_engine::Error::unknown(
                            "evaporation setting",
                            other,
                            &["transfer", "ambient"],
                        )))
                    }
                }
            }
            let Some(chi) = transfer else {
                return Err(err(format!("{call}: give #{{ transfer: χ (kg/(m²·s)), ambient: ω_a }}")));
            };
            d.model().set_evaporation(group, chi, ambient).map_err(raise)
        })
        .register_get("initial_water", |d: &mut ModelHandle| d.model().effects.moisture.settings.initial)
        .register_set("initial_water", |d: &mut ModelHandle, w: FLOAT| -> RhaiResult<()> {
            if !(w.is_finite() && w >= 0.0) {
                return Err(err(format!("initial_water is a water content ≥ 0 (kg/kg), got {w}")));
            }
            d.model().effects.moisture.settings.initial = w;
            Ok(())
        })
        .register_get("moisture_every", |d: &mut ModelHandle| INT::from(d.model().effects.moisture.settings.every))
        .register_set("moisture_every", |d: &mut ModelHandle, n: INT| -> RhaiResult<()> {
            d.model().effects.moisture.settings.every = count("moisture_every", n)?;
            Ok(())
        })
        .register_get("moisture_substeps", |d: &mut ModelHandle| {
            INT::from(d.model().effects.moisture.settings.substeps)
        })
        .register_set("moisture_substeps", |d: &mut ModelHandle, n: INT| -> RhaiResult<()> {
            d.model().effects.moisture.settings.substeps = super::fields::substeps("moisture_substeps", n)?;
            Ok(())
        })
        .register_get("moisture_bond_radius", |d: &mut ModelHandle| d.model().effects.moisture.settings.bond_radius)
        .register_set("moisture_bond_radius", |d: &mut ModelHandle, beta: FLOAT| -> RhaiResult<()> {
            if !(beta.is_finite() && (0.0..=1.0).contains(&beta)) {
                return Err(err(format!(
                    "moisture_bond_radius is a bond's neck radius as a fraction of the smaller element's, in [0, 1]; \
                     got {beta}"
                )));
            }
            d.model().effects.moisture.settings.bond_radius = beta;
            Ok(())
        })
        .register_get("water_radius_table", |d: &mut ModelHandle| {
            table_value(&d.model().effects.moisture.settings.radius_table)
        })
        .register_set("water_radius_table", |d: &mut ModelHandle, v: Dynamic| -> RhaiResult<()> {
            let t = table(&v, "d.water_radius_table")?;
            d.model().set_radius_table(t).map_err(raise)
        })
        .register_get("water_strength_table", |d: &mut ModelHandle| {
            table_value(&d.model().effects.moisture.settings.strength_table)
        })
        .register_set("water_strength_table", |d: &mut ModelHandle, v: Dynamic| -> RhaiResult<()> {
            let t = table(&v, "d.water_strength_table")?;
            d.model().set_strength_table(t).map_err(raise)
        });
}
