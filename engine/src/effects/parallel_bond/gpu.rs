//! The `parallel_bond` stage on the GPU (shaders/parallel_bond.wgsl): the pipeline, the
//! stage's own buffers (the bond rows, their states in f32, the parameters) and the kernel
//! bound to them and to the particles' lanes. Built only when the plan has the stage; a plan
//! without it has no pipeline, no buffer and no dispatch. CPU twin: `effects/parallel_bond/cpu.rs`.
//!
//! The bond rows are not split into slabs: their states (48 B a bond end) must fit one storage
//! binding, or the upload is refused with the lane's size and the limit.

use crate::backend::gpu::bindings::{Holder, Lane};
use crate::backend::gpu::buffers::{read, DeviceLanes};
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, DeviceStages, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::parallel_bond::physics::{BondState, ParallelBondParams};
use crate::error::{GpuError, Result};
use crate::model::Model;
use crate::physics::Vec3;
use crate::plan::Stage;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use wgsl as pb;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("parallel_bond");

    pub const PARAMS: Lane = lane(HOME, "bp", "BondParams");
    /// The bond rows (CSR) and their ends' states.
    pub const ROW_START: Lane = lane(HOME, "row_start", "array<u32>");
    pub const OTHER: Lane = lane(HOME, "other", "array<u32>");
    pub const BONDS: Lane = lane(HOME, "bonds", "array<Bond>");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use super::wgsl as pb;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    pub const SHADER: Shader = Shader {
        name: "parallel_bond",
        source: concat!(
            include_str!("../../../../shaders/periodic_image.wgsl"),
            "\n",
            include_str!("../../../../shaders/parallel_bond.wgsl")
        ),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            uniform(pb::PARAMS),
            read(ORIGIN),
            read(DISP),
            read(VEL),
            read(ANG_VEL),
            read(pb::ROW_START),
            read(pb::OTHER),
            read_write(pb::BONDS),
            read_write(FORCE),
            read_write(TORQUE),
            read_write(COUNTERS),
            read_write(EVENTS),
            read_write(HEAT),
        ]]),
    };
}

/// The bonds' parameters (`BondParams` in parallel_bond.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct BondParams {
    lambda: f32,
    e_star: f32,
    k_ratio: f32,
    sigma_c: f32,
    cohesion: f32,
    tan_phi: f32,
    n: u32,
    pad: u32,
}

/// One bond end (`Bond` in parallel_bond.wgsl), 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Bond {
    shear_normal: [f32; 4],
    bending_twist: [f32; 4],
    status: u32,
    pad: [u32; 3],
}

fn pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::ParallelBond.name(), &SHADER, "parallel_bond", constants)
}

/// The stage's buffers for one upload.
struct BondLanes {
    params: wgpu::Buffer,
    row_start: wgpu::Buffer,
    other: wgpu::Buffer,
    bonds: wgpu::Buffer,
    entries: usize,
    /// Bytes of the stage's buffers.
    bytes: u64,
}

impl Holder for BondLanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        Some(match lane {
            pb::PARAMS => &self.params,
            pb::ROW_START => &self.row_start,
            pb::OTHER => &self.other,
            pb::BONDS => &self.bonds,
            _ => return None,
        })
    }
}

impl BondLanes {
    /// Uploads the model's bonds (their rows fitted to the particles); refuses a lane larger
    /// than `limit` bytes.
    fn upload(ctx: &GpuContext, m: &mut Model, params: &ParallelBondParams, limit: u64) -> Result<Self> {
        let n = m.len();
        let b = &mut m.parallel_bonds;
        b.fit(n);
        let f = |x: f64| x as f32;
        let uniform = BondParams {
            lambda: f(params.lambda),
            e_star: f(params.e_star),
            k_ratio: f(params.k_ratio),
            sigma_c: f(params.sigma_c),
            cohesion: f(params.cohesion),
            tan_phi: f(params.phi.tan()),
            n: n as u32,
            pad: 0,
        };
        let v4 = |v: &Vec3, w: f64| [f(v.x), f(v.y), f(v.z), f(w)];
        let bonds: Vec<Bond> = b
            .state
            .iter()
            .map(|s| Bond {
                shear_normal: v4(&s.shear, s.normal),
                bending_twist: v4(&s.bending, s.twist),
                status: s.status,
                pad: [0; 3],
            })
            .collect();
        let mut bytes = std::mem::size_of::<BondParams>() as u64;
        let mut make = |lane: &'static str, data: &[u8]| -> Result<wgpu::Buffer> {
            // An empty lane still needs a buffer to bind.
            let zeros = [0u8; 64];
            let contents = if data.is_empty() { &zeros[..] } else { data };
            if contents.len() as u64 > limit {
                return Err(GpuError::BufferTooLarge { lane, bytes: contents.len() as u64, limit }.into());
            }
            bytes += contents.len() as u64;
            Ok(ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(lane),
                contents,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            }))
        };
        let row_start = make("parallel bond rows", bytemuck::cast_slice(&b.row_start))?;
        let other = make("parallel bond ids", bytemuck::cast_slice(&b.other))?;
        let bonds_buf = make("parallel bond states", bytemuck::cast_slice(&bonds))?;
        let params = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("parallel bond parameters"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        Ok(BondLanes { params, row_start, other, bonds: bonds_buf, entries: b.state.len(), bytes })
    }

    /// Brings the bonds' states back into the model (f32 widened to f64).
    fn download(&self, ctx: &GpuContext, m: &mut Model) -> Result<()> {
        let bonds: Vec<Bond> = read(ctx, &self.bonds, self.entries)?;
        let v = |a: &[f32; 4]| Vec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
        for (s, g) in m.parallel_bonds.state.iter_mut().zip(&bonds) {
            *s = BondState {
                shear: v(&g.shear_normal),
                normal: f64::from(g.shear_normal[3]),
                bending: v(&g.bending_twist),
                twist: f64::from(g.bending_twist[3]),
                status: g.status,
            };
        }
        Ok(())
    }
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`): the model's bonds
/// (their rows fitted to the particles) and the kernel bound to them and the particles' lanes.
pub fn upload(m: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    let Some(params) = &u.plan.parallel_bond else { return Ok(None) };
    let lanes = BondLanes::upload(u.ctx, m, params, u.limit)?;
    let kernel = Kernel::bind(&u.ctx.device, &pipeline(u.ctx, u.constants), &[u.lanes, &lanes], groups_for(u.lanes.n))?;
    Ok(Some(Box::new(Bonds { lanes, kernel })))
}

struct Bonds {
    lanes: BondLanes,
    kernel: Kernel,
}

impl DeviceStage for Bonds {
    fn kernels(&self, _: u64) -> Vec<&Kernel> {
        vec![&self.kernel]
    }

    fn bytes(&self) -> u64 {
        self.lanes.bytes
    }

    fn download(&self, ctx: &GpuContext, _: &DeviceLanes, m: &mut Model, _: &DeviceStages) -> Result<()> {
        self.lanes.download(ctx, m)
    }
}
