//! The scene's fields as scripts see them (paper 003 §3.3, issue 15): heat conduction with
//! thermal expansion and the water table. `d.enable("heat")` switches conduction on;
//! `d.temperature` is a writable whole-array field; `d.thermal(material or group, #{…})` sets
//! conductivity, specific heat and expansion; groups are held at a temperature, insulated or
//! heated; `d.water_level = z` puts the scene under water. Each name is documented in
//! scripting/api/docs.rs.

use super::*;
use matdem_engine::effects::conduction::{ThermalMode, ThermalUpdate};

/// The thermal properties a map names (conductivity, specific_heat, expansion).
fn thermal_update(props: &Map, call: &str) -> RhaiResult<ThermalUpdate> {
    let mut u = ThermalUpdate::default();
    for (k, v) in props {
        let x = number(v).ok_or_else(|| err(format!("{call}: `{k}` must be a number, got {}", v.type_name())))?;
        match k.as_str() {
            "conductivity" | "k" => u.conductivity = Some(x),
            "specific_heat" | "c" => u.specific_heat = Some(x),
            "expansion" | "alpha" => {
                // 1000× a rock's (1e-2 /K) stopped later as "loaded contacts are stiffer":
                // refuse the cause where it is given.
                if !(x.is_finite() && x.abs() <= MAX_EXPANSION) {
                    return Err(err(format!(
                        "{call}: `{k}` = {x} /K is outside ±{MAX_EXPANSION:e} /K: it is the linear expansion \
                         coefficient (rock 5e-6 to 1.5e-5 /K, plastics up to 2e-4 /K), not a percentage"
                    )));
                }
                u.expansion = Some(x)
            }
            other => {
                return Err(raise(matdem_engine::Error::unknown(
                    "thermal property",
                    other,
                    &["conductivity", "specific_heat", "expansion"],
                )))
            }
        }
    }
    Ok(u)
}

/// The largest linear thermal expansion coefficient taken, 1/K: five times a soft plastic's.
const MAX_EXPANSION: f64 = 1e-3;

/// A count ≥ 1 from a script integer.
fn count(name: &str, v: INT) -> RhaiResult<u32> {
    u32::try_from(v).ok().filter(|&c| c >= 1).ok_or_else(|| err(format!("{name} must be an integer ≥ 1, got {v}")))
}

/// Sub-steps a step: at most [`MAX_SUBSTEPS`](matdem_engine::physics::timestep::MAX_SUBSTEPS).
pub(super) fn substeps(name: &str, v: INT) -> RhaiResult<u32> {
    let most = matdem_engine::physics::timestep::MAX_SUBSTEPS;
    u32::try_from(v)
        .ok()
        .filter(|&c| (1..=most).contains(&c))
        .ok_or_else(|| err(format!("{name} must be an integer from 1 to {most}, got {v}")))
}

fn finite(name: &str, v: FLOAT) -> RhaiResult<FLOAT> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(err(format!("{name} must be a finite number, got {v}")))
    }
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_get(
            "temperature",
            observed!(host, "temperature", |d| {
                let m = d.model();
                if !m.settings.heat.enabled {
                    return Err(err("d.temperature: heat is off; call d.enable(\"heat\") first"));
                }
                let t = &m.particles.thermal.temperature;
                Field::new(if t.len() == m.len() { t.clone() } else { vec![m.settings.heat.reference; m.len()] })
            }),
        )
        .register_set("temperature", |d: &mut ModelHandle, value: Dynamic| -> RhaiResult<()> {
            let mut m = d.model();
            let n = m.len();
            let t = if let Some(x) = number(&value) {
                vec![x; n]
            } else if let Some(f) = value.clone().try_cast::<Field>() {
                f.0.to_vec()
            } else {
                return Err(err(format!("d.temperature = …: expected a number or a Field, got {}", value.type_name())));
            };
            m.set_temperatures(&t).map_err(|e| err(format!("d.temperature = …: {e}; nothing was changed")))
        })
        .register_get(
            "conductance",
            observed!(host, "conductance", |d| {
                let m = d.model();
                let g = &m.particles.thermal.conductance;
                if g.len() != m.len() {
                    return Err(err("d.conductance: heat is off; call d.enable(\"heat\") first"));
                }
                Field::new(g.clone())
            }),
        )
        .register_fn("thermal", |d: &mut ModelHandle, name: &str, props: Map| -> RhaiResult<()> {
            let call = format!("d.thermal(\"{name}\", …)");
            let u = thermal_update(&props, &call)?;
            let mut m = d.model();
            if m.material_index(name).is_ok() {
                let base = m.settings.heat.materials.get(name).copied().unwrap_or_default();
                return m.set_thermal_material(name, u.apply(base)).map_err(raise);
            }
            if m.groups.get(name).is_ok() {
                return m.set_thermal_group(name, u).map_err(raise);
            }
            Err(err(format!("{call}: `{name}` is neither a material nor a group of this model")))
        })
        .register_fn("fix_temperature", |d: &mut ModelHandle, group: &str| {
            d.model().set_thermal_mode(group, ThermalMode::Fixed(None)).map_err(raise)
        })
        .register_fn("fix_temperature", |d: &mut ModelHandle, group: &str, t: FLOAT| -> RhaiResult<()> {
            let t = kelvin("the fixed temperature", t)?;
            d.model().set_thermal_mode(group, ThermalMode::Fixed(Some(t))).map_err(raise)
        })
        .register_fn("insulate", |d: &mut ModelHandle, group: &str| {
            d.model().set_thermal_mode(group, ThermalMode::Insulated).map_err(raise)
        })
        .register_fn("free_temperature", |d: &mut ModelHandle, group: &str| {
            d.model().set_thermal_mode(group, ThermalMode::Free).map_err(raise)
        })
        .register_fn("heat_source", |d: &mut ModelHandle, group: &str, watts: FLOAT| {
            d.model().set_heat_source(group, watts).map_err(raise)
        })
        .register_get("reference_temperature", |d: &mut ModelHandle| d.model().settings.heat.reference)
        .register_set("reference_temperature", |d: &mut ModelHandle, t: FLOAT| -> RhaiResult<()> {
            d.model().settings.heat.reference = kelvin("reference_temperature", t)?;
            Ok(())
        })
        .register_get("heat_every", |d: &mut ModelHandle| INT::from(d.model().settings.heat.every))
        .register_set("heat_every", |d: &mut ModelHandle, n: INT| -> RhaiResult<()> {
            d.model().settings.heat.every = count("heat_every", n)?;
            Ok(())
        })
        .register_get("heat_substeps", |d: &mut ModelHandle| INT::from(d.model().settings.heat.substeps))
        .register_set("heat_substeps", |d: &mut ModelHandle, n: INT| -> RhaiResult<()> {
            d.model().settings.heat.substeps = substeps("heat_substeps", n)?;
            Ok(())
        })
        .register_get("heat_dissipation", |d: &mut ModelHandle| d.model().settings.heat.dissipation)
        .register_set("heat_dissipation", |d: &mut ModelHandle, on: bool| {
            let mut m = d.model();
            m.settings.heat.dissipation = on;
            m.fit_thermal();
        })
        .register_get("heat_bond_radius", |d: &mut ModelHandle| d.model().settings.heat.bond_radius)
        .register_set("heat_bond_radius", |d: &mut ModelHandle, beta: FLOAT| -> RhaiResult<()> {
            if !(beta.is_finite() && (0.0..=1.0).contains(&beta)) {
                return Err(err(format!(
                    "heat_bond_radius is a bond's neck radius as a fraction of the smaller element's, in [0, 1]; got {beta}"
                )));
            }
            d.model().settings.heat.bond_radius = beta;
            Ok(())
        })
        .register_get("water_level", |d: &mut ModelHandle| -> Dynamic {
            d.model().settings.water.level.map_or(Dynamic::UNIT, Dynamic::from_float)
        })
        .register_set("water_level", |d: &mut ModelHandle, z: FLOAT| -> RhaiResult<()> {
            let z = finite("water_level", z)?;
            d.model().set_water_level(Some(z));
            Ok(())
        })
        .register_get("fluid_density", |d: &mut ModelHandle| d.model().settings.water.density)
        .register_set("fluid_density", |d: &mut ModelHandle, rho: FLOAT| -> RhaiResult<()> {
            let rho = positive("fluid_density (kg/m³)", rho)?;
            let mut m = d.model();
            m.book_body_work();
            m.settings.water.density = rho;
            m.book_body_work();
            Ok(())
        })
        .register_get("fluid_viscosity", |d: &mut ModelHandle| d.model().settings.water.viscosity)
        .register_set("fluid_viscosity", |d: &mut ModelHandle, mu: FLOAT| -> RhaiResult<()> {
            if !(mu.is_finite() && mu >= 0.0) {
                return Err(err(format!("fluid_viscosity is a dynamic viscosity ≥ 0 Pa·s (water: 1e-3), got {mu}")));
            }
            d.model().settings.water.viscosity = mu;
            Ok(())
        });
}

/// A temperature as scripts give it: finite and absolute (K), never below absolute zero.
fn kelvin(what: &str, t: FLOAT) -> RhaiResult<FLOAT> {
    let t = finite(what, t)?;
    if t < 0.0 {
        return Err(err(format!(
            "{what} = {t} K is below absolute zero: temperatures are in kelvin (20 °C is 293.15 K)"
        )));
    }
    Ok(t)
}
