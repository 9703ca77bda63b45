//! Walls (MatDEM boundaries): motion, placement, friction, servo-controlled platens, the CPT
//! cone (`d.add_cone`, docs/cpt.md) and plane strips, the sides of the direct shear test's
//! half-boxes (`d.add_strip`, `d.limit_boundary`, docs/direct-shear.md).

use super::*;

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_fn("move_boundary", |d: &mut ModelHandle, name: &str, v: Array| -> RhaiResult<()> {
            let v = vec3(&Dynamic::from_array(v), "boundary velocity")?;
            d.model().wall_mut(name).map_err(raise)?.motion = WallMotion::Velocity(v);
            Ok(())
        })
        .register_fn("place_boundary", |d: &mut ModelHandle, name: &str, to: Array| -> RhaiResult<()> {
            let to = vec3(&Dynamic::from_array(to), "boundary position")?;
            let mut m = d.model();
            let w = m.wall_mut(name).map_err(raise)?;
            match &mut w.shape {
                matdem_engine::WallShape::Plane { point, .. } | matdem_engine::WallShape::Strip { point, .. } => {
                    *point = to
                }
                matdem_engine::WallShape::Cone { apex, .. } => *apex = to,
                matdem_engine::WallShape::Cylinder { .. } => {
                    return Err(err(format!("place_boundary: `{name}` is a ring; only planes can be placed")))
                }
            }
            Ok(())
        })
        .register_fn("remove_boundary", |d: &mut ModelHandle, name: &str| -> RhaiResult<()> {
            d.model().remove_wall(name).map_err(raise)
        })
        .register_fn("stop_boundary", |d: &mut ModelHandle, name: &str| -> RhaiResult<()> {
            d.model().wall_mut(name).map_err(raise)?.motion = WallMotion::Fixed;
            Ok(())
        })
        .register_fn("set_boundary_friction", |d: &mut ModelHandle, name: &str, mu: FLOAT| -> RhaiResult<()> {
            if !(mu.is_finite() && mu >= 0.0) {
                return Err(err(format!("friction must be ≥ 0, got {mu}")));
            }
            d.model().wall_mut(name).map_err(raise)?.friction = Some(mu);
            Ok(())
        })
        .register_fn("set_boundary_area", |d: &mut ModelHandle, name: &str, area: FLOAT| -> RhaiResult<()> {
            if !(area.is_finite() && area > 0.0) {
                return Err(err(format!("d.set_boundary_area: the area must be a finite number > 0 m², got {area}")));
            }
            d.model().wall_mut(name).map_err(raise)?.area = area;
            Ok(())
        })
        .register_fn("set_platen_stress", |d: &mut ModelHandle, name: &str, stress: FLOAT| -> RhaiResult<()> {
            set_servo(d, name, stress, None)
        })
        .register_fn("set_platen_stress", |d: &mut ModelHandle, name: &str, stress: FLOAT, max_speed: FLOAT| {
            set_servo(d, name, stress, Some(max_speed))
        })
        .register_fn(
            "boundary",
            observed!(host, "boundary", |d, name: &str| {
                let m = d.model();
                let k = m.wall_index(name).map_err(raise)?;
                let w = &m.walls[k];
                let mut map = Map::new();
                let v3 = |v: Vec3| vec![Dynamic::from_float(v.x), Dynamic::from_float(v.y), Dynamic::from_float(v.z)];
                map.insert("stress".into(), matdem_engine::status::wall_stress(&m, k).into());
                map.insert("force".into(), v3(w.force).into());
                map.insert("displacement".into(), v3(w.displacement).into());
                map.insert("contacts".into(), (w.contacts as INT).into());
                // What `stress` divides the force by: a box's side walls span the loose column
                // the grains were poured as, not the sample's height.
                map.insert("area".into(), w.area.into());
                let pos = match &w.shape {
                    matdem_engine::WallShape::Plane { point, .. } | matdem_engine::WallShape::Strip { point, .. } => {
                        v3(*point)
                    }
                    matdem_engine::WallShape::Cylinder { radius, .. } => vec![Dynamic::from_float(*radius)],
                    matdem_engine::WallShape::Cone { apex, .. } => v3(*apex),
                };
                map.insert("position".into(), pos.into());
                if let matdem_engine::WallShape::Cone { .. } = &w.shape {
                    map.insert("qc".into(), w.qc().into());
                    map.insert("fs".into(), w.fs().into());
                    map.insert("tip_force".into(), w.tip_force.into());
                    map.insert("sleeve_force".into(), w.sleeve_force.into());
                }
                map
            }),
        )
        // d.add_cone(#{ name, apex, axis, angle, radius, rod_length }): a rigid cone (apex angle
        // `angle`, degrees, 60 by default) at `apex` pointing against `axis` (default [0, 0, 1]:
        // the apex down, the rod up), continued by a rod of its base radius `radius` and length
        // `rod_length` (m). Move it with d.move_boundary; d.boundary(name) reads qc and fs.
        .register_fn("add_cone", |d: &mut ModelHandle, p: Map| -> RhaiResult<INT> {
            let wall = cone_from_map(&p)?;
            Ok(d.model().add_wall(wall).map_err(raise)? as INT)
        })
        // d.add_strip(#{ name, point, normal, axis, from, to, area }): a plane limited to a strip
        // (a half-box's side): through `point` with `normal` into the particles' region,
        // between `from` and `to` (m) along `axis` (in the plane) measured from `point`.
        .register_fn("add_strip", |d: &mut ModelHandle, p: Map| -> RhaiResult<INT> {
            let wall = strip_from_map(&p)?;
            Ok(d.model().add_wall(wall).map_err(raise)? as INT)
        })
        // d.limit_boundary(name, axis, from, to): a plane wall becomes a strip between `from`
        // and `to` along `axis`, measured from its point; it keeps its name, motion and friction.
        .register_fn(
            "limit_boundary",
            |d: &mut ModelHandle, name: &str, axis: Array, from: FLOAT, to: FLOAT| -> RhaiResult<()> {
                let axis = vec3(&Dynamic::from_array(axis), "strip axis")?;
                let mut m = d.model();
                let w = m.wall_mut(name).map_err(raise)?;
                let matdem_engine::WallShape::Plane { point, normal } = w.shape else {
                    return Err(err(format!(
                        "limit_boundary: `{name}` is not a plane; only a plane can be limited to a strip"
                    )));
                };
                let strip = matdem_engine::Wall::strip(name, point, normal, axis, from, to, w.area).map_err(raise)?;
                w.shape = strip.shape;
                if let WallMotion::Servo { .. } = w.motion {
                    w.motion = WallMotion::Fixed;
                }
                Ok(())
            },
        )
        .register_get("boundaries", |d: &mut ModelHandle| {
            d.model().walls.iter().map(|w| Dynamic::from(w.name.clone())).collect::<Array>()
        });
}

fn set_servo(d: &ModelHandle, name: &str, stress: f64, max_speed: Option<f64>) -> RhaiResult<()> {
    // A negative stress is a set-point below zero: walls carry no tension, so the platen backs
    // away at the servo's speed for that error — what an outer control loop asks when the
    // sample swells faster than the servo follows from a set-point of zero (direct_shear's).
    if !stress.is_finite() {
        return Err(err(format!("platen stress must be a finite number of Pa (compression > 0), got {stress}")));
    }
    let mut m = d.model();
    match m.walls[m.wall_index(name).map_err(raise)?].shape {
        matdem_engine::WallShape::Cone { .. } => {
            return Err(err(format!(
                "set_platen_stress: `{name}` is a cone; a cone is pushed at a speed: d.move_boundary(\"{name}\", [vx, vy, vz])"
            )))
        }
        matdem_engine::WallShape::Strip { .. } => {
            return Err(err(format!(
                "set_platen_stress: `{name}` is a strip (a half-box's side); a strip is moved at a speed: \
                 d.move_boundary(\"{name}\", [vx, vy, vz]); servo-control a plane platen instead"
            )))
        }
        _ => {}
    }
    let dt = m.clock.dt;
    if dt <= 0.0 {
        return Err(err("set the time step first (set_standard_dt) so the servo can choose its speed"));
    }
    // Default speed limit: 0.2% of the mean radius per step keeps the platen quasi-static.
    let max_speed = match max_speed {
        Some(v) => positive("max_speed", v)?,
        None => 2e-3 * m.mean_radius() / dt,
    };
    m.wall_mut(name).map_err(raise)?.motion = WallMotion::Servo { stress, max_speed };
    Ok(())
}

/// A wall's map (`d.add_cone`, `d.add_strip`) as read by its builder: unknown keys refused
/// with the nearest known one, missing keys and values of the wrong type named.
struct WallMap<'a> {
    map: &'a Map,
    what: &'static str,
}

impl<'a> WallMap<'a> {
    fn new(map: &'a Map, what: &'static str, kind: &'static str, keys: &[&str]) -> RhaiResult<Self> {
        if let Some(k) = map.keys().find(|k| !keys.contains(&k.as_str())) {
            let e = matdem_engine::Error::unknown(kind, k.as_str(), keys);
            return Err(err(format!("{what}: {e}")));
        }
        Ok(WallMap { map, what })
    }

    fn need(&self, key: &str) -> RhaiResult<&'a Dynamic> {
        self.map.get(key).ok_or_else(|| err(format!("{}: missing `{key}`", self.what)))
    }

    fn num(&self, key: &str) -> RhaiResult<f64> {
        let v = self.need(key)?;
        number(v).ok_or_else(|| err(format!("{}: `{key}` must be a number, got {}", self.what, v.type_name())))
    }

    /// A number that may be left out.
    fn num_or(&self, key: &str, default: f64) -> RhaiResult<f64> {
        if self.map.contains_key(key) {
            self.num(key)
        } else {
            Ok(default)
        }
    }

    fn name(&self) -> RhaiResult<String> {
        let what = self.what;
        self.need("name")?.clone().into_string().map_err(|t| err(format!("{what}: `name` must be a string, got {t}")))
    }
}

/// The keys of `d.add_cone`'s map.
const CONE_KEYS: [&str; 6] = ["name", "apex", "axis", "angle", "radius", "rod_length"];

/// `d.add_cone`'s map as a wall; the engine checks the ranges.
fn cone_from_map(map: &Map) -> RhaiResult<matdem_engine::Wall> {
    let m = WallMap::new(map, "add_cone", "cone key", &CONE_KEYS)?;
    let apex = vec3(m.need("apex")?, "cone apex")?;
    let axis = match map.get("axis") {
        Some(v) => vec3(v, "cone axis")?,
        None => Vec3::z(),
    };
    let angle = m.num_or("angle", 60.0)?;
    let (radius, rod_length) = (m.num("radius")?, m.num("rod_length")?);
    matdem_engine::Wall::cone(&m.name()?, apex, axis, (0.5 * angle).to_radians(), radius, rod_length).map_err(raise)
}

/// The keys of `d.add_strip`'s map.
const STRIP_KEYS: [&str; 7] = ["name", "point", "normal", "axis", "from", "to", "area"];

/// `d.add_strip`'s map as a wall; the engine checks the geometry.
fn strip_from_map(map: &Map) -> RhaiResult<matdem_engine::Wall> {
    let m = WallMap::new(map, "add_strip", "strip key", &STRIP_KEYS)?;
    let point = vec3(m.need("point")?, "strip point")?;
    let normal = vec3(m.need("normal")?, "strip normal")?;
    let axis = vec3(m.need("axis")?, "strip axis")?;
    let (from, to, area) = (m.num("from")?, m.num("to")?, m.num_or("area", 0.0)?);
    matdem_engine::Wall::strip(&m.name()?, point, normal, axis, from, to, area).map_err(raise)
}
