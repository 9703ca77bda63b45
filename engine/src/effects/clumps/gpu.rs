//! The `clumps` stage on the GPU (shaders/clumps.wgsl): the bodies, each clump's first member and
//! the members with their offsets, uploaded with the model; one dispatch a step, one invocation
//! per clump, after the move. A download brings the bodies back. Built only when the plan has the
//! stage. CPU twin: `effects/clumps/cpu.rs`.

use crate::backend::gpu::bindings::{Holder, Lane};
use crate::backend::gpu::buffers::{read, DeviceLanes};
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, DeviceStages, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel};
use crate::effects::clumps::lanes::Body;
use crate::error::Result;
use crate::model::Model;
use crate::physics::Vec3;
use crate::plan::Stage;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use wgsl as cl;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("clumps");

    /// Per clump its body (`ClumpBody`).
    pub const BODIES: Lane = lane(HOME, "clump_bodies", "array<ClumpBody>");
    /// Clump c's members are entries `clump_start[c]..clump_start[c + 1]` of `clump_members`.
    pub const START: Lane = lane(HOME, "clump_start", "array<u32>");
    /// Per member its offset in the principal frame (xyz) and its element (w, the u32's bits).
    pub const MEMBERS: Lane = lane(HOME, "clump_members", "array<vec4<f32>>");
}

pub use shader::SHADER;

mod shader {
    use super::cl;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    pub const SHADER: Shader = Shader {
        name: "clumps",
        source: concat!(
            include_str!("../../../../shaders/periodic_image.wgsl"),
            "\n",
            include_str!("../../../../shaders/clumps.wgsl")
        ),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read(ORIGIN),
            read_write(DISP),
            read_write(VEL),
            read(BODY),
            read(FORCE),
            read(TORQUE),
            read_write(ANG_VEL),
            read_write(ANGLE),
            read_write(HEAT),
            read_write(cl::BODIES),
            read(cl::START),
            read(cl::MEMBERS),
        ]]),
    };
}

/// `ClumpBody` in clumps.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct DeviceBody {
    pos0: [f32; 4],
    dpos: [f32; 4],
    vel: [f32; 4],
    ang_mom: [f32; 4],
    q: [f32; 4],
    inertia: [f32; 4],
}

fn v4(v: &Vec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn v3(a: &[f32; 4]) -> Vec3 {
    Vec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]))
}

impl DeviceBody {
    fn of(b: &Body) -> Self {
        let pos0 = Vec3::new(f64::from(b.pos.x as f32), f64::from(b.pos.y as f32), f64::from(b.pos.z as f32));
        let [w, x, y, z] = b.orientation;
        DeviceBody {
            pos0: v4(&pos0, b.mass as f32),
            dpos: v4(&(b.pos - pos0), 0.0),
            vel: v4(&b.vel, 0.0),
            ang_mom: v4(&b.ang_mom, 0.0),
            q: [x as f32, y as f32, z as f32, w as f32],
            inertia: v4(&b.inertia, 0.0),
        }
    }

    /// The body it holds, over `b` (mass and moments stay the host's).
    fn onto(&self, b: &mut Body) {
        b.pos = v3(&self.pos0) + v3(&self.dpos);
        b.vel = v3(&self.vel);
        b.ang_mom = v3(&self.ang_mom);
        let q = nalgebra::Quaternion::new(
            f64::from(self.q[3]),
            f64::from(self.q[0]),
            f64::from(self.q[1]),
            f64::from(self.q[2]),
        );
        b.set_rotation(nalgebra::UnitQuaternion::from_quaternion(q));
    }
}

/// The stage's buffers and kernel for one upload.
struct Session {
    bodies: wgpu::Buffer,
    start: wgpu::Buffer,
    members: wgpu::Buffer,
    kernel: Option<Kernel>,
    count: usize,
    bytes: u64,
}

impl Holder for Session {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        match lane {
            cl::BODIES => Some(&self.bodies),
            cl::START => Some(&self.start),
            cl::MEMBERS => Some(&self.members),
            _ => None,
        }
    }
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`): the model's clumps,
/// and the stage's kernel bound to them and the particles' lanes.
pub fn upload(m: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    if u.plan.clumps.is_none() {
        return Ok(None);
    }
    let (ctx, c) = (u.ctx, &m.clumps);
    let bodies: Vec<DeviceBody> = c.bodies.iter().map(DeviceBody::of).collect();
    let members: Vec<[f32; 4]> = c
        .members
        .iter()
        .zip(&c.offsets)
        .map(|(&j, o)| [o.x as f32, o.y as f32, o.z as f32, f32::from_bits(j)])
        .collect();
    let make = |label, contents: &[u8]| {
        ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        })
    };
    let mut s = Session {
        bodies: make("clump bodies", bytemuck::cast_slice(&bodies)),
        start: make("clump starts", bytemuck::cast_slice(&c.member_start)),
        members: make("clump members", bytemuck::cast_slice(&members)),
        kernel: None,
        count: bodies.len(),
        bytes: (bodies.len() * std::mem::size_of::<DeviceBody>() + c.member_start.len() * 4 + members.len() * 16)
            as u64,
    };
    let pipeline = shaders::pipeline(ctx, Stage::Clumps.name(), &SHADER, "clumps", u.constants);
    s.kernel = Some(Kernel::bind(&ctx.device, &pipeline, &[u.lanes, &s], groups_for(s.count))?);
    Ok(Some(Box::new(s)))
}

impl DeviceStage for Session {
    fn kernels(&self, _: u64) -> Vec<&Kernel> {
        self.kernel.iter().collect()
    }

    fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Brings the bodies back into `m` (the members come with the elements' lanes).
    fn download(&self, ctx: &GpuContext, _: &DeviceLanes, m: &mut Model, _: &DeviceStages) -> Result<()> {
        let bodies = read::<DeviceBody>(ctx, &self.bodies, self.count)?;
        for (d, b) in bodies.iter().zip(&mut m.clumps.bodies) {
            d.onto(b);
        }
        Ok(())
    }
}
