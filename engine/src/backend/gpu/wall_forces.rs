//! The `wall_forces` stage on the GPU: particle–wall contacts and per-workgroup wall loads
//! (shaders/wall_forces.wgsl), one kernel per slab. Built only when the scene has walls.
//! CPU twin: `backend/cpu/wall_forces.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, Kernel};
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
    shaders::pipeline(device, Stage::WallForces.name(), shaders::WALL_FORCES, "compute_wall_forces", constants)
}

pub fn kernels(device: &wgpu::Device, p: &wgpu::ComputePipeline, d: &DeviceLanes) -> Vec<Kernel> {
    d.per_slab(device, p, |s| {
        vec![
            &d.params,
            &d.origin,
            &d.disp,
            &d.vel,
            &d.body,
            &d.kind,
            &d.walls,
            &d.wall_pairs,
            &s.wall_state,
            &d.force,
            &d.ang_vel,
            &d.torque,
            &d.partials,
            &s.uniform,
            &d.heat,
        ]
    })
}

/// Workgroups of the wall pass over all slabs (slabs start on a workgroup boundary): one
/// load partial per workgroup and wall.
pub fn partial_groups(n: usize) -> usize {
    n.div_ceil(super::memory::WORKGROUP).max(1)
}
