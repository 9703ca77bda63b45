//! Walls (MatDEM boundaries): motion, placement, friction, servo-controlled platens.

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
                matdem_engine::WallShape::Plane { point, .. } => *point = to,
                matdem_engine::WallShape::Cylinder { .. } => {
                    return Err(err(format!("place_boundary: `{name}` is a ring; only planes can be placed")))
                }
            }
            Ok(())
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
                let pos = match &w.shape {
                    matdem_engine::WallShape::Plane { point, .. } => v3(*point),
                    matdem_engine::WallShape::Cylinder { radius, .. } => vec![Dynamic::from_float(*radius)],
                };
                map.insert("position".into(), pos.into());
                map
            }),
        )
        .register_get("boundaries", |d: &mut ModelHandle| {
            d.model().walls.iter().map(|w| Dynamic::from(w.name.clone())).collect::<Array>()
        });
}

fn set_servo(d: &ModelHandle, name: &str, stress: f64, max_speed: Option<f64>) -> RhaiResult<()> {
    if !(stress.is_finite() && stress >= 0.0) {
        return Err(err(format!("platen stress must be a finite number ≥ 0 Pa, got {stress}")));
    }
    let mut m = d.model();
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
