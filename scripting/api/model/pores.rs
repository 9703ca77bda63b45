//! Pore density flow as scripts see it (paper 003 §3.3, issue 16): `d.enable("pore_flow")`
//! builds the pore network of the packing and couples the fluid into every step (the
//! `pore_flow` stage); `d.fluid = #{ bulk_modulus, density, viscosity, … }` sets the fluid;
//! `d.fix_pore_pressure(group, box or borehole, p)`, `d.inject(point, rate)`,
//! `d.fix_pore_pressure_at(point, p)` and `d.seal_pores()` set the boundaries (everything
//! else is impermeable); `d.pore_pressure` (per element), `d.pore_pressures` (per pore),
//! `d.permeability` and `d.pore_network` read the state. With heat on, each pore's fluid has a
//! temperature: `d.fluid`'s `specific_heat`, `expansion`, `thermal_conductivity` and `nusselt`,
//! a temperature as the last argument of `d.inject` and `d.fix_pore_pressure[_at]` (the
//! fluid the region supplies), `d.pore_temperature` (per element) and `d.pore_temperatures`
//! (per pore). `d.fluid = #{ permeability: #{ clay: 0.01 } }` tightens a material's throats.
//! Each name is documented in scripting/api/docs.rs; the physics in docs/pore-flow.md.

use super::*;
use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, PoreRegion};

const FLUID_KEYS: &[&str] = &[
    "bulk_modulus",
    "density",
    "viscosity",
    "max_substeps",
    "rebuild_drift",
    "cement_factor",
    "crack_aperture",
    "specific_heat",
    "expansion",
    "thermal_conductivity",
    "nusselt",
    "permeability",
];

fn fluid_map(f: &Fluid) -> Map {
    let mut m = Map::new();
    m.insert("bulk_modulus".into(), Dynamic::from_float(f.bulk_modulus));
    m.insert("density".into(), Dynamic::from_float(f.density));
    m.insert("viscosity".into(), Dynamic::from_float(f.viscosity));
    m.insert("max_substeps".into(), Dynamic::from_int(INT::from(f.max_substeps)));
    m.insert("rebuild_drift".into(), Dynamic::from_float(f.rebuild_drift));
    m.insert("cement_factor".into(), Dynamic::from_float(f.cement_factor));
    m.insert("crack_aperture".into(), Dynamic::from_float(f.crack_aperture));
    m.insert("specific_heat".into(), Dynamic::from_float(f.heat.specific_heat));
    m.insert("expansion".into(), Dynamic::from_float(f.heat.expansion));
    m.insert("thermal_conductivity".into(), Dynamic::from_float(f.heat.conductivity));
    m.insert("nusselt".into(), Dynamic::from_float(f.heat.nusselt));
    let factors: Map = f.permeability.iter().map(|(k, v)| (k.as_str().into(), Dynamic::from_float(*v))).collect();
    m.insert("permeability".into(), Dynamic::from_map(factors));
    m
}

/// The fluid with the map's keys changed (the others kept).
fn fluid_update(base: &Fluid, props: &Map) -> RhaiResult<Fluid> {
    let mut f = base.clone();
    for (k, v) in props {
        if k.as_str() == "permeability" {
            // Factors by material name; a map replaces the earlier factors of the names it holds.
            let map = v.clone().try_cast::<Map>().ok_or_else(|| {
                err(format!(
                    "d.fluid = #{{…}}: `permeability` must be a map of factors by material name, e.g. #{{ clay: 0.01 \
                     }}, got {}",
                    v.type_name()
                ))
            })?;
            for (name, x) in map {
                let x = number(&x).ok_or_else(|| {
                    err(format!("d.fluid = #{{…}}: the permeability factor of `{name}` must be a number"))
                })?;
                f.permeability.insert(name.to_string(), x);
            }
            continue;
        }
        let x =
            number(v).ok_or_else(|| err(format!("d.fluid = #{{…}}: `{k}` must be a number, got {}", v.type_name())))?;
        match k.as_str() {
            "bulk_modulus" | "K_f" => f.bulk_modulus = x,
            "density" | "rho0" => f.density = x,
            "viscosity" | "mu" => f.viscosity = x,
            "max_substeps" => {
                f.max_substeps = u32::try_from(x as i64)
                    .ok()
                    .filter(|&n| n >= 1 && x.fract() == 0.0)
                    .ok_or_else(|| err(format!("d.fluid = #{{…}}: max_substeps must be a whole number ≥ 1, got {x}")))?
            }
            "rebuild_drift" => f.rebuild_drift = x,
            "cement_factor" => f.cement_factor = x,
            "crack_aperture" => f.crack_aperture = x,
            "specific_heat" | "c_f" => f.heat.specific_heat = x,
            "expansion" | "beta_f" => f.heat.expansion = x,
            "thermal_conductivity" | "k_f" => f.heat.conductivity = x,
            "nusselt" => f.heat.nusselt = x,
            other => return Err(raise(matdem_engine::Error::unknown("fluid property", other, FLUID_KEYS))),
        }
    }
    f.check().map_err(|e| {
        err(format!(
            "d.fluid = #{{…}}: {e}; nothing was changed (water: bulk_modulus 2.2e9 Pa, density 1000 kg/m³, viscosity \
             1e-3 Pa·s, specific_heat 4186 J/(kg·K), expansion 2.1e-4 /K, thermal_conductivity 0.6 W/(m·K); a \
             softer fluid or a more viscous one gives a longer stable flow step)"
        ))
    })?;
    Ok(f)
}

/// A boundary region from a script value: a group name, "all", ids or a mask (the pores those
/// elements bound), a box #{ lo: [x, y, z], hi: [x, y, z] } or a borehole #{ center: [x, y, z],
/// axis: [x, y, z], radius: r } (the pores whose centres lie in it).
fn region(m: &Model, sel: &Dynamic, call: &str) -> RhaiResult<PoreRegion> {
    if let Some(map) = sel.clone().try_cast::<Map>() {
        if map.contains_key("center") || map.contains_key("axis") || map.contains_key("radius") {
            let usage = "a borehole is #{ center: [x, y, z], axis: [x, y, z], radius: r }";
            let get = |k: &str| map.get(k).ok_or_else(|| err(format!("{call}: {usage}; `{k}` is missing")));
            let center = vec3(get("center")?, &format!("{call}: `center`"))?;
            let axis = vec3(get("axis")?, &format!("{call}: `axis`"))?;
            let radius = get("radius")?;
            let radius = radius
                .as_float()
                .or_else(|_| radius.as_int().map(|r| r as FLOAT))
                .map_err(|_| err(format!("{call}: `radius` must be a number (m)")))?;
            return PoreRegion::cylinder(center, axis, radius).map_err(|e| err(format!("{call}: {e}")));
        }
        let corner = |k: &str| -> RhaiResult<Vec3> {
            let v = map.get(k).ok_or_else(|| err(format!("{call}: a box needs `lo` and `hi` corners, [x, y, z]")))?;
            vec3(v, &format!("{call}: `{k}`"))
        };
        let (lo, hi) = (corner("lo")?, corner("hi")?);
        if (0..3).any(|i| lo[i] > hi[i]) {
            return Err(err(format!("{call}: the box's `lo` corner must be below its `hi` corner on every axis")));
        }
        return Ok(PoreRegion::Box { lo, hi });
    }
    let ids =
        resolve_ids(m, sel).map_err(|e| err(format!("{call}: {e} (or a box #{{ lo: [x, y, z], hi: [x, y, z] }}, or a borehole #{{ center: [x, y, z], axis: [x, y, z], radius: r }})")))?;
    if ids.is_empty() {
        return Err(err(format!("{call}: the selection holds no element; give a group with elements or a box")));
    }
    Ok(PoreRegion::Elements(ids))
}

fn finite(name: &str, v: FLOAT) -> RhaiResult<FLOAT> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(err(format!("{name} must be a finite number, got {v}")))
    }
}

const OFF: &str = "pore flow is off; call d.enable(\"pore_flow\") first";

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_get("fluid", |d: &mut ModelHandle| fluid_map(&d.model().settings.pores.fluid))
        .register_set("fluid", |d: &mut ModelHandle, props: Map| -> RhaiResult<()> {
            let mut m = d.model();
            let f = fluid_update(&m.settings.pores.fluid, &props)?;
            m.set_pore_fluid(f).map_err(raise)
        })
        .register_fn("fix_pore_pressure", |d: &mut ModelHandle, sel: Dynamic, p: FLOAT| -> RhaiResult<()> {
            let call = "d.fix_pore_pressure(group, box or borehole, p)";
            let p = finite("the fixed pore pressure (Pa, gauge)", p)?;
            let mut m = d.model();
            let r = region(&m, &sel, call)?;
            m.add_pore_boundary(r, BoundaryKind::Pressure(p)).map_err(raise)
        })
        .register_fn("fix_pore_pressure_at", |d: &mut ModelHandle, point: Array, p: FLOAT| -> RhaiResult<()> {
            let x = vec3(&Dynamic::from_array(point), "d.fix_pore_pressure_at(point, p): point")?;
            let p = finite("the fixed pore pressure (Pa, gauge)", p)?;
            d.model().add_pore_boundary(PoreRegion::Point(x), BoundaryKind::Pressure(p)).map_err(raise)
        })
        .register_fn("inject", |d: &mut ModelHandle, point: Array, rate: FLOAT| -> RhaiResult<()> {
            let x = vec3(&Dynamic::from_array(point), "d.inject(point, rate): point")?;
            let q = finite("the injection rate (m³/s at ρ0; negative draws fluid out)", rate)?;
            d.model().add_pore_boundary(PoreRegion::Point(x), BoundaryKind::Flux(q)).map_err(raise)
        })
        .register_fn("inject", |d: &mut ModelHandle, sel: Dynamic, rate: FLOAT| -> RhaiResult<()> {
            let q = finite("the injection rate (m³/s at ρ0; negative draws fluid out)", rate)?;
            let mut m = d.model();
            let r = region(&m, &sel, "d.inject(group, box or borehole, rate)")?;
            m.add_pore_boundary(r, BoundaryKind::Flux(q)).map_err(raise)
        })
        .register_fn("fix_pore_pressure", |d: &mut ModelHandle, sel: Dynamic, p: FLOAT, t: FLOAT| -> RhaiResult<()> {
            let call = "d.fix_pore_pressure(group, box or borehole, p, T)";
            let p = finite("the fixed pore pressure (Pa, gauge)", p)?;
            let t = finite("the reservoir's temperature (K)", t)?;
            let mut m = d.model();
            let r = region(&m, &sel, call)?;
            m.add_pore_boundary_at(r, BoundaryKind::Pressure(p), Some(t)).map_err(raise)
        })
        .register_fn(
            "fix_pore_pressure_at",
            |d: &mut ModelHandle, point: Array, p: FLOAT, t: FLOAT| -> RhaiResult<()> {
                let x = vec3(&Dynamic::from_array(point), "d.fix_pore_pressure_at(point, p, T): point")?;
                let p = finite("the fixed pore pressure (Pa, gauge)", p)?;
                let t = finite("the reservoir's temperature (K)", t)?;
                d.model().add_pore_boundary_at(PoreRegion::Point(x), BoundaryKind::Pressure(p), Some(t)).map_err(raise)
            },
        )
        .register_fn("inject", |d: &mut ModelHandle, point: Array, rate: FLOAT, t: FLOAT| -> RhaiResult<()> {
            let x = vec3(&Dynamic::from_array(point), "d.inject(point, rate, T): point")?;
            let q = finite("the injection rate (m³/s at ρ0; negative draws fluid out)", rate)?;
            let t = finite("the injected fluid's temperature (K)", t)?;
            d.model().add_pore_boundary_at(PoreRegion::Point(x), BoundaryKind::Flux(q), Some(t)).map_err(raise)
        })
        .register_fn("inject", |d: &mut ModelHandle, sel: Dynamic, rate: FLOAT, t: FLOAT| -> RhaiResult<()> {
            let q = finite("the injection rate (m³/s at ρ0; negative draws fluid out)", rate)?;
            let t = finite("the injected fluid's temperature (K)", t)?;
            let mut m = d.model();
            let r = region(&m, &sel, "d.inject(group, box or borehole, rate, T)")?;
            m.add_pore_boundary_at(r, BoundaryKind::Flux(q), Some(t)).map_err(raise)
        })
        .register_fn("seal_pores", |d: &mut ModelHandle| d.model().clear_pore_boundaries().map_err(raise))
        .register_get(
            "pore_pressure",
            observed!(host, "pore_pressure", |d| {
                let m = d.model();
                let f = m.pores.as_ref().ok_or_else(|| err(format!("d.pore_pressure: {OFF}")))?;
                let mut p = f.element_pressure(&m.particles.pos);
                p.resize(m.len(), 0.0);
                Field::new(p)
            }),
        )
        .register_get(
            "pore_pressures",
            observed!(host, "pore_pressures", |d| {
                let m = d.model();
                let f = m.pores.as_ref().ok_or_else(|| err(format!("d.pore_pressures: {OFF}")))?;
                f.pressure.iter().map(|&p| Dynamic::from_float(p)).collect::<Array>()
            }),
        )
        .register_get(
            "pore_temperature",
            observed!(host, "pore_temperature", |d| {
                let m = d.model();
                let f = m.pores.as_ref().ok_or_else(|| err(format!("d.pore_temperature: {OFF}")))?;
                if f.temperature.is_empty() {
                    return Err(err("d.pore_temperature: the pore fluid has no temperature while heat is off; call \
                         d.enable(\"heat\") (the pores take their temperatures at the next step)"));
                }
                let mut t = f.element_temperature(&m.particles.pos);
                t.resize(m.len(), f.reference);
                Field::new(t)
            }),
        )
        .register_get(
            "pore_temperatures",
            observed!(host, "pore_temperatures", |d| {
                let m = d.model();
                let f = m.pores.as_ref().ok_or_else(|| err(format!("d.pore_temperatures: {OFF}")))?;
                f.temperature.iter().map(|&t| Dynamic::from_float(t)).collect::<Array>()
            }),
        )
        .register_get(
            "permeability",
            observed!(host, "permeability", |d| {
                let m = d.model();
                let f = m.pores.as_ref().ok_or_else(|| err(format!("d.permeability: {OFF}")))?;
                let mut out = Map::new();
                let mut porosity = 0.0;
                for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
                    let k = f.permeability(&m.particles.pos, axis).map_err(|e| err(format!("d.permeability: {e}")))?;
                    porosity = k.porosity;
                    out.insert(name.into(), Dynamic::from_float(k.k));
                }
                out.insert("porosity".into(), Dynamic::from_float(porosity));
                out
            }),
        )
        .register_get(
            "pore_network",
            observed!(host, "pore_network", |d| {
                let m = d.model();
                let f = m.pores.as_ref().ok_or_else(|| err(format!("d.pore_network: {OFF}")))?;
                let (pore, crit) = f.critical_dt();
                let mut out = Map::new();
                let int = |x: usize| Dynamic::from_int(x as INT);
                out.insert("pores".into(), int(f.network.pore_count()));
                out.insert("throats".into(), int(f.network.throats.len()));
                out.insert("rebuilds".into(), int(f.rebuilds as usize));
                out.insert("substeps".into(), int(f.substeps as usize));
                out.insert("fluid_mass".into(), Dynamic::from_float(f.total_mass()));
                out.insert("boundary_mass".into(), Dynamic::from_float(f.boundary_mass));
                out.insert("critical_dt".into(), Dynamic::from_float(crit));
                out.insert("critical_pore".into(), int(pore));
                let max = f.pressure.iter().cloned().fold(f64::MIN, f64::max);
                out.insert("max_pressure".into(), Dynamic::from_float(max));
                out.insert("mean_pressure".into(), Dynamic::from_float(f.mean_pressure()));
                out.insert("pore_volume".into(), Dynamic::from_float(f.pore_volume()));
                let floats = |v: &[f64]| v.iter().map(|&x| Dynamic::from_float(x)).collect::<Array>();
                out.insert("region_mass".into(), Dynamic::from_array(floats(&f.region_mass)));
                out.insert("region_heat".into(), Dynamic::from_array(floats(&f.region_heat)));
                out.insert("fluid_heat".into(), Dynamic::from_float(f.fluid_heat()));
                out.insert("exchange_substeps".into(), int(f.exchange_substeps as usize));
                out
            }),
        );
}
