//! The `guard` stage on the GPU: the stability guard's checks (shaders/guard.wgsl), run at
//! every chunk end (`guard_every` steps). When one fails the host brings the state back and
//! words the CPU guard's message ([`crate::guard`]), so both backends stop with the same text.
//! The stiffness check (a contact too stiff for dt) costs one pass over the rows per chunk on
//! the device and one counter in the read-back the batch makes anyway; the state comes back
//! only when it fires.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::Guard.name(), &shaders::GUARD, "check_state", constants)
}

/// One kernel per slab of rows.
pub fn kernels(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Vec<Kernel>> {
    d.slabs.iter().map(|s| Kernel::bind(device, p, &[d, s], groups_for(s.count))).collect()
}

/// What each guard slot means, worded as the CPU guard words it.
pub const FAILURES: [&str; 4] = [
    "has a non-finite position, velocity or force",
    "moves more than 50% of its radius per step",
    "overlaps a neighbour by more than the allowed fraction of the smaller radius",
    "is pushed through a wall",
];
