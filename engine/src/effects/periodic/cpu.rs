//! The `periodic` stage on the CPU, right after the move (and the clumps' step): each element
//! that left the cell comes back through the opposite face, its displacement's origin shifted
//! with it; a clump comes back whole, its centre wrapped and its members carried along (they may
//! reach out of the cell: pairs meet through the nearest image and the cell list wraps). Under
//! Lees–Edwards shear the images' offset first advances by γ̇·L_z·dt, and an element or clump
//! crossing a z face moves along x by the offset and changes its x velocity by the slide,
//! continuing as the image it was. CPU twin of `gpu.rs`.

use crate::effects::clumps::lanes::Clumps;
use crate::effects::periodic::setting::Periodic;
use crate::model::Model;
use crate::physics::Vec3;
use crate::state::particles::{dof, Particles};

/// Advances the shear's offset and wraps every element and clump into the cell.
pub fn periodic(m: &mut Model) {
    let dt = m.clock.dt;
    let Some(cell) = m.settings.periodic.as_mut() else { return };
    if let (Some(s), Some([x0, x1]), Some([z0, z1])) = (cell.shear.as_mut(), cell.axes[0], cell.axes[2]) {
        s.offset = (s.offset + s.rate * (z1 - z0) * dt).rem_euclid(x1 - x0);
    }
    let cell = *cell;
    wrap_all(&cell, &mut m.particles, &mut m.clumps);
}

/// Puts every element and clump into `cell`: an element by itself, a clump's members with its
/// centre (the stage each step, and a cell when it is made).
pub fn wrap_all(cell: &Periodic, p: &mut Particles, clumps: &mut Clumps) {
    for i in 0..p.len() {
        // A clump's members move with its centre, below.
        if p.fixed[i] & dof::CLUMPED != 0 {
            continue;
        }
        let (shift, kick) = cell.wrap_sliding(&mut p.pos[i]);
        if shift != Vec3::zeros() {
            p.origin[i] += shift;
        }
        if kick != 0.0 {
            p.vel[i].x += kick;
        }
    }
    for c in 0..clumps.len() {
        wrap_clump(cell, clumps, p, c);
    }
}

/// Wraps clump `c`'s centre into the cell and carries its members (positions, displacement
/// origins and, under Lees–Edwards shear, x velocities) with it.
pub fn wrap_clump(cell: &Periodic, clumps: &mut Clumps, p: &mut Particles, c: usize) {
    let b = &mut clumps.bodies[c];
    let (shift, kick) = cell.wrap_sliding(&mut b.pos);
    if shift == Vec3::zeros() && kick == 0.0 {
        return;
    }
    b.vel.x += kick;
    for k in clumps.range(c) {
        let j = clumps.members[k] as usize;
        p.pos[j] += shift;
        p.origin[j] += shift;
        p.vel[j].x += kick;
    }
}
