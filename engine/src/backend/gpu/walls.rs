//! The `walls` stage on the GPU: the wall loads of the last step are summed and the walls move
//! (prescribed velocity or servo), in one single-workgroup dispatch (shaders/walls.wgsl),
//! so a servo platen runs without a round trip to the host. Built only when the scene has
//! walls. CPU twin: [`crate::walls::Wall::advance`].

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, Kernel, Pipeline};
use crate::error::Result;
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::Walls.name(), &shaders::WALLS, "advance_walls", constants)
}

/// The loads alone (no move), so the host reads the loads of the run's last step.
pub fn sum_pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, "sum_wall_loads", &shaders::WALLS, "sum_wall_loads", constants)
}

pub fn kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Kernel> {
    Kernel::bind(device, p, &[d], (1, 1))
}
