//! The `contact_forces` stage on the GPU: particle–particle contact forces
//! (shaders/contact_forces.wgsl). Each invocation walks its own row, so there are no float atomics
//! and the sums are the same in every run. One kernel per slab of rows. CPU twin:
//! `backend/cpu/contact_forces.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, Kernel};
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
    shaders::pipeline(device, Stage::ContactForces.name(), shaders::CONTACT_FORCES, "compute_contact_forces", constants)
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
            &d.row_len,
            &s.other,
            &s.state,
            &d.pairs,
            &d.force,
            &d.ang_vel,
            &d.torque,
            &d.counters,
            &d.events,
            &s.uniform,
            &s.dashpot,
            &d.heat,
        ]
    })
}
