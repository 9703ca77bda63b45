//! Whole-array lanes of the model (MatDEM `d.mo.aX`): positions, radii, velocities, angular
//! velocities, forces, displacements, masses, and the micro values kn ks xb fs0 mu_p (written
//! by copy-on-write of the elements' materials, `matdem_engine::element_values`). Reads are observations (journaled for resume);
//! writes (`d.x = field`, `d.set("vx", ids, value)`) are actions a resumed run repeats.
//!
//! A write checks every value before it changes anything, so a refused write leaves the
//! model as it was. Between runs the host copy of the model is the truth on every backend
//! (a GPU run uploads the model at its start and downloads it at its end), so a write needs
//! no sync of its own.

use super::*;
use matdem_engine::element_values::ElementValue;

fn lane(d: &ModelHandle, f: impl Fn(&Model, usize) -> f64) -> Field {
    let m = d.model();
    Field::new((0..m.len()).map(|i| f(&m, i)).collect())
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    // Whole-array lanes (a sync point on the GPU later).
    macro_rules! lane_get {
        ($name:literal, $f:expr) => {
            engine.register_get($name, observed!(host, $name, |d| lane(d, $f)));
        };
    }
    lane_get!("x", |m, i| m.particles.pos[i].x);
    lane_get!("y", |m, i| m.particles.pos[i].y);
    lane_get!("z", |m, i| m.particles.pos[i].z);
    lane_get!("r", |m, i| m.particles.radius[i]);
    lane_get!("vx", |m, i| m.particles.vel[i].x);
    lane_get!("vy", |m, i| m.particles.vel[i].y);
    lane_get!("vz", |m, i| m.particles.vel[i].z);
    lane_get!("fx", |m, i| m.particles.force[i].x);
    lane_get!("fy", |m, i| m.particles.force[i].y);
    lane_get!("fz", |m, i| m.particles.force[i].z);
    lane_get!("dx", |m, i| m.particles.pos[i].x - m.particles.origin[i].x);
    lane_get!("dy", |m, i| m.particles.pos[i].y - m.particles.origin[i].y);
    lane_get!("dz", |m, i| m.particles.pos[i].z - m.particles.origin[i].z);
    lane_get!("displacement", |m, i| (m.particles.pos[i] - m.particles.origin[i]).norm());
    lane_get!("mass", |m, i| m.particles.mass[i]);
    lane_get!("material", |m, i| m.particles.material[i] as f64);
    // Per-element micro values (MatDEM d.mo.aKN …), from each element's material.
    for which in ElementValue::ALL {
        let (h, name) = (host.clone(), which.name());
        engine.register_get(name, move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
            h.observe(name, || Ok(Dynamic::from(Field::new(d.model().element_values(which)))))
        });
    }
    for (k, name) in ["wx", "wy", "wz"].into_iter().enumerate() {
        let h = host.clone();
        engine.register_get(name, move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
            h.observe(name, || {
                let m = d.model();
                let rot = m.particles.rotation.as_ref().ok_or_else(|| err(rotation_off(name)))?;
                Ok(Dynamic::from(Field::new(rot.ang_vel.iter().map(|w| w[k]).collect())))
            })
        });
    }
    for lane in Lane::ALL {
        let name = lane.name();
        engine.register_set(name, move |d: &mut ModelHandle, value: Dynamic| {
            write_lane(&mut d.model(), lane, None, &value, &format!("d.{name} = …"))
        });
    }
    engine.register_fn("set", |d: &mut ModelHandle, name: &str, sel: Dynamic, value: Dynamic| -> RhaiResult<()> {
        let lane = Lane::parse(name)?;
        let mut m = d.model();
        let ids = resolve_ids(&m, &sel)?;
        write_lane(&mut m, lane, Some(ids), &value, &format!("d.set(\"{name}\", …)"))
    });
    engine
        .register_get("contact_load", observed!(host, "contact_load", |d| Field::new(d.data().sim.contact_loads())))
        .register_get("n", |d: &mut ModelHandle| d.model().len() as INT)
        .register_get("name", |d: &mut ModelHandle| d.data().name.clone());
}

/// A lane a script may write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lane {
    /// Position component x, y or z (m).
    Pos(usize),
    /// Velocity component (m/s).
    Vel(usize),
    /// Angular velocity component (rad/s); only with rotation on.
    AngVel(usize),
    /// Radius (m); mass and inertia follow.
    Radius,
    /// A micro value (kn ks xb fs0 mu_p), by copy-on-write of the elements' materials.
    Micro(ElementValue),
}

impl Lane {
    const ALL: [Lane; 15] = [
        Lane::Pos(0),
        Lane::Pos(1),
        Lane::Pos(2),
        Lane::Vel(0),
        Lane::Vel(1),
        Lane::Vel(2),
        Lane::AngVel(0),
        Lane::AngVel(1),
        Lane::AngVel(2),
        Lane::Radius,
        Lane::Micro(ElementValue::Kn),
        Lane::Micro(ElementValue::Ks),
        Lane::Micro(ElementValue::Xb),
        Lane::Micro(ElementValue::Fs0),
        Lane::Micro(ElementValue::MuP),
    ];

    fn name(self) -> &'static str {
        const XYZ: [[&str; 3]; 3] = [["x", "y", "z"], ["vx", "vy", "vz"], ["wx", "wy", "wz"]];
        match self {
            Lane::Pos(k) => XYZ[0][k],
            Lane::Vel(k) => XYZ[1][k],
            Lane::AngVel(k) => XYZ[2][k],
            Lane::Radius => "r",
            Lane::Micro(v) => v.name(),
        }
    }

    fn parse(name: &str) -> RhaiResult<Lane> {
        Lane::ALL.into_iter().find(|l| l.name() == name).ok_or_else(|| {
            let known: Vec<&str> = Lane::ALL.iter().map(|l| l.name()).collect();
            let hint = matdem_engine::error::did_you_mean(name, &known);
            err(format!("d.set: `{name}` is not a writable lane{hint}; writable: {}", known.join(", ")))
        })
    }
}

fn rotation_off(lane: &str) -> String {
    format!(
        "`{lane}`: rotation is off, so the model has no angular velocities; switch it on first with \
         d.enable(\"rotation\")"
    )
}

/// Writes `value` (a number, or a Field of the selection's length or of the model's) into
/// `lane` for the particles `ids` (all when `None`). Checks every value first: a wrong
/// length, a NaN or infinity, or a radius ≤ 0 is refused naming the first bad particle,
/// and nothing changes.
fn write_lane(m: &mut Model, lane: Lane, ids: Option<Vec<u32>>, value: &Dynamic, call: &str) -> RhaiResult<()> {
    let n = m.len();
    let whole = ids.is_none();
    let ids = ids.unwrap_or_else(|| (0..n as u32).collect());
    let values: Vec<f64> = if let Some(x) = number(value) {
        vec![x; ids.len()]
    } else if let Some(f) = value.clone().try_cast::<Field>() {
        if f.0.len() == ids.len() {
            f.0.to_vec()
        } else if f.0.len() == n {
            ids.iter().map(|&i| f.0[i as usize]).collect()
        } else if whole {
            return Err(err(format!(
                "{call}: the field has {} values but the model has {n} particles; give one value per particle \
                 (or a number for all); nothing was changed",
                f.0.len()
            )));
        } else {
            return Err(err(format!(
                "{call}: the field has {} values, but the selection has {} particles and the model {n}; \
                 give one value per selected particle or one per particle of the model; nothing was changed",
                f.0.len(),
                ids.len()
            )));
        }
    } else {
        return Err(err(format!("{call}: expected a number or a Field, got {}", value.type_name())));
    };
    if let Lane::AngVel(_) = lane {
        if m.particles.rotation.is_none() {
            return Err(err(format!("{call}: {}", rotation_off(lane.name()))));
        }
    }
    let bad = |v: f64| {
        !v.is_finite()
            || match lane {
                Lane::Radius | Lane::Micro(ElementValue::Kn) => v <= 0.0,
                Lane::Micro(_) => v < 0.0,
                _ => false,
            }
    };
    if let Some(k) = values.iter().position(|&v| bad(v)) {
        let what = match lane {
            Lane::Radius => "a finite number > 0 m",
            Lane::Micro(ElementValue::Kn) => "a finite number > 0 N/m",
            Lane::Micro(_) => "a finite number ≥ 0",
            _ => "a finite number",
        };
        return Err(err(format!(
            "{call}: particle {} (value {k}) would get {} = {}; each value must be {what}; nothing was changed",
            ids[k],
            lane.name(),
            values[k]
        )));
    }
    // A 2D model's elements stay in its plane: y, vy, and the spin about x and z are its.
    if m.planar().is_some() && matches!(lane, Lane::Pos(1) | Lane::Vel(1) | Lane::AngVel(0) | Lane::AngVel(2)) {
        if let Some(k) = values.iter().position(|&v| v != 0.0) {
            return Err(err(format!(
                "{call}: the model is 2D (x–z plane) and `{}` must stay 0 there, got {} (value {k}); nothing was changed",
                lane.name(),
                values[k]
            )));
        }
    }
    if let Lane::Vel(_) | Lane::AngVel(_) = lane {
        // A killed element stays at rest: a velocity would move it (its blocked degrees of
        // freedom keep the velocity they have).
        if let Some(k) = ids.iter().position(|&i| m.is_killed(i as usize)) {
            return Err(err(format!(
                "{call}: particle {} (value {k}) was killed (d.kill) and stays at rest; leave the killed elements \
                 out of the selection (& !d.killed); nothing was changed",
                ids[k]
            )));
        }
    }
    let p = &mut m.particles;
    match lane {
        Lane::Pos(c) => {
            for (&i, &v) in ids.iter().zip(&values) {
                p.pos[i as usize][c] = v;
            }
            m.positions_changed();
        }
        Lane::Vel(c) => {
            for (&i, &v) in ids.iter().zip(&values) {
                p.vel[i as usize][c] = v;
            }
        }
        Lane::AngVel(c) => {
            let rot = p.rotation.as_mut().ok_or_else(|| err(rotation_off(lane.name())))?;
            for (&i, &v) in ids.iter().zip(&values) {
                rot.ang_vel[i as usize][c] = v;
            }
        }
        Lane::Radius => m.set_radii(&ids, &values).map_err(raise)?,
        Lane::Micro(which) => {
            m.set_element_values(which, &ids, &values).map_err(|e| err(format!("{call}: {e}")))?;
        }
    }
    Ok(())
}
