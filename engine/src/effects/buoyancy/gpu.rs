//! The `buoyancy` stage on the GPU (shaders/buoyancy.wgsl): the water table's buoyant force
//! (and Stokes drag) added to the force lane, every step, after the other force stages and
//! before `integrate`, booking the drag's heat in the ledger's damping slot. Built only when the
//! plan has the stage; its one buffer is the water's uniform (level, fluid density, 6π·μ). CPU
//! twin: `effects/buoyancy/cpu.rs`.

use crate::backend::gpu::buffers::DeviceLanes;
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::buoyancy::BuoyancyPlan;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use wgpu::util::DeviceExt;
use wgsl::WATER;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("buoyancy");

    /// Level, fluid density, 6π·μ (`Water` in buoyancy.wgsl).
    pub const WATER: Lane = lane(HOME, "water", "Water");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use super::wgsl as by;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    pub const SHADER: Shader = Shader {
        name: "buoyancy",
        source: include_str!("../../../../shaders/buoyancy.wgsl"),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read(ORIGIN),
            read(DISP),
            read(BODY),
            read(VEL),
            read_write(FORCE),
            uniform(by::WATER),
            read(KIND),
            read_write(HEAT),
        ]]),
    };
}

fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::Buoyancy.name(), &SHADER, "buoyancy", constants)
}

/// The water's uniform (`Water` in buoyancy.wgsl).
fn water(ctx: &GpuContext, plan: &BuoyancyPlan) -> wgpu::Buffer {
    let words = [plan.level as f32, plan.density as f32, (6.0 * std::f64::consts::PI * plan.viscosity) as f32, 0.0f32];
    ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("water"),
        contents: bytemuck::cast_slice(&words),
        usage: wgpu::BufferUsages::UNIFORM,
    })
}

fn kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes, water: &wgpu::Buffer) -> Result<Kernel> {
    Kernel::bind(device, p, &[d, &(WATER, water)], groups_for(d.n))
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`): the water's uniform
/// lives in the kernel's bind group; no lane of its own.
pub fn upload(_: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    let Some(b) = &u.plan.buoyancy else { return Ok(None) };
    let kernel = kernel(&u.ctx.device, &pipeline(u.ctx, u.constants), u.lanes, &water(u.ctx, b))?;
    Ok(Some(Box::new(Upload(kernel))))
}

struct Upload(Kernel);

impl DeviceStage for Upload {
    fn kernels(&self, _: u64) -> Vec<&Kernel> {
        vec![&self.0]
    }

    fn bytes(&self) -> u64 {
        0
    }
}
