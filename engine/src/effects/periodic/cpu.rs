//! The `periodic` stage on the CPU, right after the move: each element that left the cell comes
//! back through the opposite face, its displacement's origin shifted with it; under Lees–Edwards
//! shear the images' offset first advances by γ̇·L_z·dt, and an element crossing a z face moves
//! along x by the offset and changes its x velocity by the slide, continuing as the image it was.
//! CPU twin of `gpu.rs`.

use crate::model::Model;
use crate::physics::Vec3;

/// Advances the shear's offset and wraps every element into the cell.
pub fn periodic(m: &mut Model) {
    let dt = m.clock.dt;
    let Some(cell) = m.settings.periodic.as_mut() else { return };
    if let (Some(s), Some([x0, x1]), Some([z0, z1])) = (cell.shear.as_mut(), cell.axes[0], cell.axes[2]) {
        s.offset = (s.offset + s.rate * (z1 - z0) * dt).rem_euclid(x1 - x0);
    }
    let cell = *cell;
    let p = &mut m.particles;
    for ((x, o), v) in p.pos.iter_mut().zip(p.origin.iter_mut()).zip(p.vel.iter_mut()) {
        let (shift, kick) = cell.wrap_sliding(x);
        if shift != Vec3::zeros() {
            *o += shift;
        }
        if kick != 0.0 {
            v.x += kick;
        }
    }
}
