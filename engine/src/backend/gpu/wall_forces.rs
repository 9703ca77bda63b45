//! The `wall_forces` stage on the GPU: particle–wall contacts and per-workgroup wall loads
//! (shaders/wall_forces.wgsl), one kernel per slab. Built only when the scene has walls. When
//! no force stage runs between it and integration, the pass integrates each particle too.
//! CPU twin: `backend/cpu/wall_forces.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::plan::Stage;

/// The wall pass; with `integrates`, the one that also moves each particle it finishes
/// (shaders/wall_forces_integrate.wgsl): for plans with walls and no force stage between the
/// two, one dispatch a step fewer. With `loads`, it leaves the load partials of those walls
/// only (bit w for wall w; none: no touch mask, no reduction tree, no barrier), and those of
/// every wall without: the particles' forces and motion are the same bits either way.
pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)], integrates: bool, loads: Option<u32>) -> Pipeline {
    let mut constants = constants.to_vec();
    if let Some(mask) = loads {
        constants.push(("STEP_LOADS", f64::from(mask)));
    }
    if integrates {
        let (shader, entry) = (&shaders::WALL_FORCES_INTEGRATE, "compute_wall_forces_and_integrate");
        return shaders::pipeline(device, "wall_forces + integrate", shader, entry, &constants);
    }
    shaders::pipeline(device, Stage::WallForces.name(), &shaders::WALL_FORCES, "compute_wall_forces", &constants)
}

pub fn kernels(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Vec<Kernel>> {
    d.slabs.iter().map(|s| Kernel::bind(device, p, &[d, s], groups_for(s.count))).collect()
}

/// Workgroups of the wall pass over all slabs (slabs start on a workgroup boundary): one
/// load partial per workgroup and wall.
pub fn partial_groups(n: usize) -> usize {
    n.div_ceil(super::memory::WORKGROUP).max(1)
}
