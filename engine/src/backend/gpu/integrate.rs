//! The `integrate` stage on the GPU: body forces, damping and leapfrog integration
//! (shaders/integrate.wgsl). CPU twin: `backend/cpu/integrate.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::Integrate.name(), &shaders::INTEGRATE, "integrate", constants)
}

pub fn kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Kernel> {
    Kernel::bind(device, p, &[d], groups_for(d.n))
}
