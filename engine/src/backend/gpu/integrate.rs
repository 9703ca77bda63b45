//! The `integrate` stage on the GPU: body forces, damping and leapfrog integration
//! (shaders/integrate.wgsl). CPU twin: `backend/cpu/integrate.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel};
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
    shaders::pipeline(device, Stage::Integrate.name(), shaders::INTEGRATE, "integrate", constants)
}

pub fn kernel(device: &wgpu::Device, p: &wgpu::ComputePipeline, d: &DeviceLanes) -> Kernel {
    let buffers = [
        &d.params,
        &d.origin,
        &d.body,
        &d.kind,
        &d.force,
        &d.vel,
        &d.disp,
        &d.torque,
        &d.ang_vel,
        &d.counters,
        &d.heat,
        &d.angle,
    ];
    Kernel::bind(device, p, &buffers, groups_for(d.n))
}
