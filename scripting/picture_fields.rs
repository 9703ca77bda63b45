//! What a particle picture shows of a model: the per-particle fields it can be coloured by
//! (their values and labels), the particles it draws and its title. `show` (`api::plot`) and a
//! movie's frames ([`crate::movie`]) draw the same way.

use matdem_engine::Model;

/// The per-particle fields a picture (`show`) or a movie (`movie_every`) can be coloured by.
pub const PICTURE_FIELDS: &[&str] = &[
    "x",
    "y",
    "z",
    "r",
    "dx",
    "dy",
    "dz",
    "displacement",
    "vx",
    "vy",
    "vz",
    "speed",
    "fx",
    "fy",
    "fz",
    "mass",
    "material",
    "size_class",
    "contact_load",
    "temperature",
    "water",
];

/// The values of the per-particle field `name` of `m` (one of [`PICTURE_FIELDS`]) and its
/// label with units; `contact_loads` gives the contact loads when they are asked for. The
/// error says what to do.
pub fn field_values(
    m: &Model,
    name: &str,
    contact_loads: impl FnOnce(&Model) -> Vec<f64>,
) -> Result<(Vec<f64>, String), String> {
    let n = m.len();
    let p = &m.particles;
    let each = |f: &dyn Fn(usize) -> f64| (0..n).map(f).collect::<Vec<f64>>();
    let v: Vec<f64> = match name {
        "x" => each(&|i| p.pos[i].x),
        "y" => each(&|i| p.pos[i].y),
        "z" => each(&|i| p.pos[i].z),
        "r" | "radius" => p.radius.clone(),
        "dx" => each(&|i| p.pos[i].x - p.origin[i].x),
        "dy" => each(&|i| p.pos[i].y - p.origin[i].y),
        "dz" => each(&|i| p.pos[i].z - p.origin[i].z),
        "displacement" => each(&|i| (p.pos[i] - p.origin[i]).norm()),
        "vx" => each(&|i| p.vel[i].x),
        "vy" => each(&|i| p.vel[i].y),
        "vz" => each(&|i| p.vel[i].z),
        "speed" => each(&|i| p.vel[i].norm()),
        "fx" => each(&|i| p.force[i].x),
        "fy" => each(&|i| p.force[i].y),
        "fz" => each(&|i| p.force[i].z),
        "mass" => p.mass.clone(),
        "material" => p.material.iter().map(|&k| k as f64).collect(),
        "size_class" => {
            let mut v = vec![0.0; n];
            for k in 1.. {
                match m.groups.get(&format!("class{k}")) {
                    Ok(ids) => ids.iter().for_each(|&i| v[i as usize] = k as f64),
                    Err(_) => break,
                }
            }
            v
        }
        "contact_load" | "force" => contact_loads(m),
        "temperature" => {
            let t = &p.thermal.temperature;
            if t.len() != n {
                return Err("no temperature field: call d.enable(\"heat\") first (docs/fields.md)".into());
            }
            t.clone()
        }
        "water" => {
            let w = &m.effects.moisture.lanes.water;
            if w.len() != n {
                return Err("no water field: call d.enable(\"moisture\") first (docs/fields.md)".into());
            }
            w.clone()
        }
        other => return Err(matdem_engine::Error::unknown("particle field", other, PICTURE_FIELDS).to_string()),
    };
    let label = match name {
        "displacement" | "dx" | "dy" | "dz" | "x" | "y" | "z" | "r" | "radius" => format!("{name} [m]"),
        "vx" | "vy" | "vz" | "speed" => format!("{name} [m/s]"),
        "fx" | "fy" | "fz" => format!("{name} [N]"),
        "mass" => "mass [kg]".to_string(),
        "contact_load" | "force" => "contact load [N]".to_string(),
        "temperature" => "temperature [K]".to_string(),
        "water" => "water content [kg/kg]".to_string(),
        other => other.to_string(),
    };
    Ok((v, label))
}

/// The particles a picture of `m` draws: those not killed and, with `slice`, within that
/// distance of the model's mid-plane in y, so the inside of a sample shows.
pub fn pictured(m: &Model, slice: Option<f64>) -> Vec<usize> {
    let p = &m.particles;
    let n = p.len().max(1) as f64;
    let y_mid = p.pos.iter().map(|x| x.y).sum::<f64>() / n;
    // Killed elements (d.kill) are out of the model: not drawn.
    (0..p.len()).filter(|&i| !m.is_killed(i) && slice.is_none_or(|w| (p.pos[i].y - y_mid).abs() <= w)).collect()
}

/// A picture's title: the model, the field and the slice, if any.
pub fn picture_title(model: &str, label: &str, slice: Option<f64>) -> String {
    match slice {
        Some(w) => format!("{model} — {label} (slice |y − ȳ| ≤ {w:.2e} m)"),
        None => format!("{model} — {label}"),
    }
}
