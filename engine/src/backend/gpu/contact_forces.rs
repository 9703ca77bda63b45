//! The `contact_forces` stage on the GPU: particle–particle contact forces
//! (shaders/contact_forces.wgsl). Each invocation walks its own row, so there are no float atomics
//! and the sums are the same in every run. One kernel per slab of rows. CPU twin:
//! `backend/cpu/contact_forces.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(
        device,
        Stage::ContactForces.name(),
        &shaders::CONTACT_FORCES,
        "compute_contact_forces",
        constants,
    )
}

pub fn kernels(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Vec<Kernel>> {
    d.slabs.iter().map(|s| Kernel::bind(device, p, &[d, s], groups_for(s.count))).collect()
}
