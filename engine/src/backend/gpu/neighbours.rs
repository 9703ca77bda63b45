//! The `neighbours` stage on the GPU: the drift measure that decides when neighbour rows are
//! rebuilt (shaders/neighbours.wgsl). The rows themselves are built on the device
//! ([`super::rows`]); how many steps may pass before the next measure is the engine's drift rule
//! ([`crate::neighbours::steps_until_rebuild`]).

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::Neighbours.name(), &shaders::NEIGHBOURS, "measure_drift", constants)
}

pub fn kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Kernel> {
    Kernel::bind(device, p, &[d], groups_for(d.n))
}
