//! Whole-array lanes of the model (MatDEM `d.mo.aX`): positions, radii, velocities, forces,
//! displacements, masses.

use super::*;

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
    engine
        .register_get("contact_load", observed!(host, "contact_load", |d| Field::new(d.data().sim.contact_loads())))
        .register_get("n", |d: &mut ModelHandle| d.model().len() as INT)
        .register_get("name", |d: &mut ModelHandle| d.data().name.clone());
}
