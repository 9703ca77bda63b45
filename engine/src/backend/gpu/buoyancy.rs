//! The `buoyancy` stage on the GPU (shaders/buoyancy.wgsl): the water table's buoyant force
//! (and Stokes drag) added to the force lane, every step, after the other force stages and
//! before `integrate`, booking the drag's heat in the ledger's damping slot. Built only when the
//! plan has the stage; its one buffer is the water's uniform (level, fluid density, 6π·μ). CPU
//! twin: `backend/cpu/buoyancy.rs`.

use super::bindings::buoyancy::WATER;
use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::fields::BuoyancyPlan;
use crate::plan::Stage;
use wgpu::util::DeviceExt;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::Buoyancy.name(), &shaders::BUOYANCY, "buoyancy", constants)
}

/// The water's uniform (`Water` in buoyancy.wgsl).
pub fn water(ctx: &GpuContext, plan: &BuoyancyPlan) -> wgpu::Buffer {
    let words = [plan.level as f32, plan.density as f32, (6.0 * std::f64::consts::PI * plan.viscosity) as f32, 0.0f32];
    ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("water"),
        contents: bytemuck::cast_slice(&words),
        usage: wgpu::BufferUsages::UNIFORM,
    })
}

pub fn kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes, water: &wgpu::Buffer) -> Result<Kernel> {
    Kernel::bind(device, p, &[d, &(WATER, water)], groups_for(d.n))
}
