//! The `applied_loads` stage on the GPU (shaders/applied_loads.wgsl): each element's applied force
//! (and torque, `APPLIED_TORQUE`, a constant of this pipeline alone) added to its force (and
//! torque) lane, every step, after the other force stages but buoyancy and before `integrate`.
//! Built only when the plan has the stage; its lanes (the loads as vec4<f32>, the torques a
//! 128-byte placeholder without any) are uploaded with the model and only read: a download brings
//! nothing back (the loads are the model's, their work is booked on the host). CPU twin:
//! `effects/applied_loads/cpu.rs`.

use crate::backend::gpu::bindings::{Holder, Lane};
use crate::backend::gpu::buffers::{storage_lane, DeviceLanes};
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::applied_loads::AppliedLoadsPlan;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;

use wgsl as al;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("applied_loads");

    pub const FORCE: Lane = lane(HOME, "applied_force", "array<vec4<f32>>");
    /// A placeholder when no element carries a torque.
    pub const TORQUE: Lane = lane(HOME, "applied_torque", "array<vec4<f32>>");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use super::wgsl as al;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    pub const SHADER: Shader = Shader {
        name: "applied_loads",
        source: include_str!("../../../../shaders/applied_loads.wgsl"),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read(KIND),
            read(al::FORCE),
            read(al::TORQUE),
            read_write(FORCE),
            read_write(TORQUE),
        ]]),
    };
}

fn pipeline(device: &GpuContext, constants: &[(&str, f64)], plan: &AppliedLoadsPlan) -> Pipeline {
    let mut constants = constants.to_vec();
    constants.push(("APPLIED_TORQUE", if plan.torques { 1.0 } else { 0.0 }));
    let name = Stage::AppliedLoads.name();
    shaders::pipeline(device, name, &SHADER, name, &constants)
}

/// The stage's lanes on the device.
struct Lanes {
    /// Each element's applied force (N), xyz of a vec4<f32>.
    pub force: wgpu::Buffer,
    /// Each element's applied torque (N·m); a placeholder when the plan has no torque.
    pub torque: wgpu::Buffer,
    /// Bytes of both.
    pub bytes: u64,
}

impl Lanes {
    /// Uploads the model's loads (f32) for `plan`, refusing a lane over `limit` bytes.
    fn upload(ctx: &GpuContext, m: &Model, plan: &AppliedLoadsPlan, limit: u64) -> Result<Self> {
        let a = &m.particles.applied;
        let v4 = |v: &crate::physics::Vec3| [v.x as f32, v.y as f32, v.z as f32, 0.0f32];
        let force: Vec<[f32; 4]> = a.force.iter().map(v4).collect();
        let torque: Vec<[f32; 4]> = if plan.torques { a.torque.iter().map(v4).collect() } else { Vec::new() };
        let mut bytes = 0;
        let force = storage_lane(ctx, "applied force", bytemuck::cast_slice(&force), 128, limit, &mut bytes)?;
        let torque = storage_lane(ctx, "applied torque", bytemuck::cast_slice(&torque), 128, limit, &mut bytes)?;
        Ok(Lanes { force, torque, bytes })
    }
}

fn kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes, loads: &Lanes) -> Result<Kernel> {
    Kernel::bind(device, p, &[d, loads], groups_for(d.n))
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`): the loads' lanes live
/// in the kernel's bind group (read only: nothing to download).
pub fn upload(m: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    let Some(a) = &u.plan.applied_loads else { return Ok(None) };
    let lanes = Lanes::upload(u.ctx, m, a, u.limit)?;
    let kernel = kernel(&u.ctx.device, &pipeline(u.ctx, u.constants, a), u.lanes, &lanes)?;
    Ok(Some(Box::new(Upload { kernel, bytes: lanes.bytes })))
}

struct Upload {
    kernel: Kernel,
    bytes: u64,
}

impl DeviceStage for Upload {
    fn kernels(&self, _: u64) -> Vec<&Kernel> {
        vec![&self.kernel]
    }

    fn bytes(&self) -> u64 {
        self.bytes
    }
}

impl Holder for Lanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        match lane {
            al::FORCE => Some(&self.force),
            al::TORQUE => Some(&self.torque),
            _ => None,
        }
    }
}
