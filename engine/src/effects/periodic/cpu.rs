//! The `periodic` stage on the CPU, right after the move (and the clumps' step): each element
//! that left the cell comes back through the opposite face, its displacement's origin shifted
//! with it; a clump comes back whole, its centre wrapped and its members carried along (they may
//! reach out of the cell: pairs meet through the nearest image and the cell list wraps). Under
//! Lees–Edwards shear the images' offset first advances by γ̇·L_z·dt, and an element or clump
//! crossing a z face moves along x by the offset and changes its x velocity by the slide,
//! continuing as the image it was. CPU twin of `gpu.rs`.

use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::periodic::wrap::wrap_all;
use crate::model::Model;
use crate::plan::StepPlan;

/// The stage's pass (`backend::cpu::stage::Build`).
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, _: &StageInput| {
        periodic(m);
        Ok(Booked::default())
    })
}

/// Advances the shear's offset and wraps every element and clump into the cell.
pub fn periodic(m: &mut Model) {
    let dt = m.clock.dt;
    let Some(cell) = m.effects.periodic.cell.as_mut() else { return };
    if let (Some(s), Some([x0, x1]), Some([z0, z1])) = (cell.shear.as_mut(), cell.axes[0], cell.axes[2]) {
        s.offset = (s.offset + s.rate * (z1 - z0) * dt).rem_euclid(x1 - x0);
    }
    let cell = *cell;
    wrap_all(&cell, &mut m.particles, &mut m.clumps);
}
