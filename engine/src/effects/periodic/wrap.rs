//! Wrapping elements and clumps into a periodic cell: what the `periodic` stage does each step
//! (`cpu.rs`, twin of `gpu.rs`) and what making a cell or a clump in one does once (the model's
//! calls), so that model-level code never names the CPU pass.

use crate::effects::clumps::lanes::Clumps;
use crate::effects::periodic::setting::Periodic;
use crate::physics::Vec3;
use crate::state::particles::{dof, Particles};

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
