//! The `periodic` stage on the CPU, right after the move: each element that left the cell comes
//! back through the opposite face, its displacement's origin shifted with it. CPU twin of `gpu.rs`.

use crate::effects::periodic::Periodic;
use crate::model::Model;

/// Wraps every element into the cell.
pub fn periodic(m: &mut Model, cell: &Periodic) {
    let p = &mut m.particles;
    for (x, o) in p.pos.iter_mut().zip(p.origin.iter_mut()) {
        let shift = cell.wrap(x);
        if shift != crate::physics::Vec3::zeros() {
            *o += shift;
        }
    }
}
