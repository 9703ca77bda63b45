//! Observation: records into `d.status`, energies, contact statistics, porosity.

use super::*;
use matdem_engine::status::{coordination_without_rattlers, wall_stress};

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_fn("record", {
            let h = host.clone();
            move |d: &mut ModelHandle| {
                push_recorded(d, h.observe("record", || record(d, &Map::new()).map(Dynamic::from))?)
            }
        })
        .register_fn("record", {
            let h = host.clone();
            move |d: &mut ModelHandle, extra: Map| {
                push_recorded(d, h.observe("record", || record(d, &extra).map(Dynamic::from))?)
            }
        })
        .register_get("status", |d: &mut ModelHandle| d.data().status.clone())
        .register_fn(
            "energies",
            observed!(host, "energies", |d| {
                let e = d.data().sim.energies();
                let mut map = Map::new();
                for (k, v) in [
                    ("kinetic", e.kinetic),
                    ("normal_elastic", e.normal_elastic),
                    ("shear_elastic", e.shear_elastic),
                    ("gravity", e.gravity),
                    ("buoyancy", e.buoyancy),
                    ("confining", e.confining),
                    ("heat_damping", e.heat_damping),
                    ("heat_contact_damping", e.heat_contact_damping),
                    ("heat_friction", e.heat_friction),
                    ("heat_breakage", e.heat_breakage),
                    ("wall_work", e.wall_work),
                    ("body_work", e.body_work),
                    ("applied_work", e.applied_work),
                    ("total", e.total()),
                ] {
                    map.insert(k.into(), v.into());
                }
                map
            }),
        )
        .register_fn(
            "coordination_number",
            observed!(host, "coordination_number", |d| d.data().sim.contact_stats().coordination),
        )
        .register_fn(
            "mechanical_coordination",
            observed!(host, "mechanical_coordination", |d| {
                let c = coordination_without_rattlers(&d.model());
                Map::from_iter([
                    ("coordination".into(), Dynamic::from_float(c.coordination)),
                    ("rattlers".into(), Dynamic::from_int(c.rattlers as INT)),
                    ("counted".into(), Dynamic::from_int(c.counted as INT)),
                ])
            }),
        )
        .register_fn(
            "mean_contact_force",
            observed!(host, "mean_contact_force", |d| d.data().sim.contact_stats().mean_normal_force),
        )
        .register_fn(
            "unbalanced_ratio",
            observed!(host, "unbalanced_ratio", |d| d.data().sim.contact_stats().unbalanced_ratio),
        )
        .register_fn(
            "porosity_cylinder",
            observed!(host, "porosity_cylinder", |d, radius: FLOAT, z0: FLOAT, z1: FLOAT| {
                if !(radius.is_finite() && radius > 0.0 && z0.is_finite() && z1.is_finite() && z0 < z1) {
                    return Err(err(format!(
                        "porosity_cylinder: the window must have a radius > 0 and z0 < z1 (finite, m), \
                         got radius {radius}, z0 {z0}, z1 {z1}; give the lower height first"
                    )));
                }
                porosity(&d.model(), &Region::Cylinder { center: Vec3::zeros(), radius, z0, z1 })
            }),
        )
        .register_fn(
            "porosity_box",
            observed!(host, "porosity_box", |d, lo: Array, hi: Array| {
                let (lo, hi) = (vec3(&Dynamic::from_array(lo), "lo")?, vec3(&Dynamic::from_array(hi), "hi")?);
                if let Some(k) = (0..3).find(|&k| lo[k] >= hi[k]) {
                    let axis = ["x", "y", "z"][k];
                    return Err(err(format!(
                        "porosity_box: the window is empty or inverted along {axis} (lo {} ≥ hi {}); \
                         give the lower corner first: porosity_box([x0, y0, z0], [x1, y1, z1]) with x0 < x1, y0 < y1, z0 < z1",
                        lo[k], hi[k]
                    )));
                }
                porosity(&d.model(), &Region::Box { lo, hi })
            }),
        )
        .register_fn(
            "to_string",
            observed!(host, "to_string", |d| {
                let data = d.data();
                let m = &data.sim.model;
                format!(
                    "Model `{}`: {} particles, {} walls, step {}, t = {:.4e} s, dt = {:.3e} s",
                    data.name,
                    m.len(),
                    m.walls.len(),
                    m.clock.step,
                    m.clock.time,
                    m.clock.dt
                )
            }),
        );
}

/// Appends a row to `d.status`: the standard quantities plus the script's own. Returns the
/// row as `[name, value]` pairs (in column order) for the journal; a replay appends the
/// journaled row instead (see [`push_recorded`]).
fn record(d: &ModelHandle, extra: &Map) -> RhaiResult<Array> {
    let extra = row_from_map(extra)?;
    let mut data = d.data();
    let stats = data.sim.contact_stats();
    let e = data.sim.energies();
    let m = &data.sim.model;
    let mut row = vec![
        ("step".to_string(), m.clock.step as f64),
        ("time".to_string(), m.clock.time),
        ("kinetic_energy".to_string(), e.kinetic),
        ("elastic_energy".to_string(), e.normal_elastic + e.shear_elastic),
        ("heat".to_string(), e.heat()),
        ("coordination".to_string(), stats.coordination),
        ("mean_contact_force".to_string(), stats.mean_normal_force),
        ("unbalanced_ratio".to_string(), stats.unbalanced_ratio),
        ("bonds".to_string(), stats.bonds as f64),
        ("broken_bonds".to_string(), m.breakages.len() as f64),
    ];
    for (k, w) in m.walls.iter().enumerate() {
        row.push((format!("{}_stress", w.name), wall_stress(m, k)));
        if let matdem_engine::WallShape::Cone { .. } = w.shape {
            row.push((format!("{}_qc", w.name), w.qc()));
            row.push((format!("{}_fs", w.name), w.fs()));
        }
    }
    let t = &m.particles.thermal.temperature;
    // Over the elements still in the model (killed ones keep the temperature they had).
    let alive: Vec<f64> = (0..t.len()).filter(|&i| !m.is_killed(i)).map(|i| t[i]).collect();
    if m.settings.heat.enabled && t.len() == m.len() && !alive.is_empty() {
        row.push(("mean_temperature".to_string(), alive.iter().sum::<f64>() / alive.len() as f64));
        row.push(("max_temperature".to_string(), alive.iter().copied().fold(f64::NEG_INFINITY, f64::max)));
    }
    let w = &m.effects.moisture.lanes.water;
    if m.effects.moisture.settings.enabled && w.len() == m.len() && !w.is_empty() {
        // Σ m·ω / Σ m: the mass-weighted mean, so that it follows the total water.
        let total = m.total_water();
        row.push(("mean_water".to_string(), total / m.particles.mass.iter().sum::<f64>()));
        row.push(("total_water".to_string(), total));
    }
    // The applied loads' work, once a scene has applied some.
    if m.particles.applied.allocated(m.len()) || m.particles.applied.booked != 0.0 {
        row.push(("applied_work".to_string(), e.applied_work));
    }
    row.extend(extra);
    Ok(row.into_iter().map(|(k, v)| Dynamic::from_array(vec![k.into(), v.into()])).collect())
}

/// Appends a row given as `[name, value]` pairs to `d.status`.
fn push_recorded(d: &ModelHandle, row: Dynamic) -> RhaiResult<()> {
    let pairs = row.try_cast::<Array>().ok_or_else(|| err("internal error: a record row is not an array"))?;
    let row = pairs
        .into_iter()
        .map(|p| {
            let p = p.try_cast::<Array>().unwrap_or_default();
            match (p.first().and_then(|k| k.clone().into_string().ok()), p.get(1).and_then(|v| v.as_float().ok())) {
                (Some(k), Some(v)) => Ok((k, v)),
                _ => Err(err("internal error: a record row entry is not [name, value]")),
            }
        })
        .collect::<RhaiResult<Vec<_>>>()?;
    d.data().status.0.borrow_mut().push(&row);
    Ok(())
}
