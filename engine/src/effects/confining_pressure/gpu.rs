//! The `confining_pressure` stage on the GPU (shaders/confining_pressure.wgsl): the membrane's
//! cells as three words (the largest reach's bits, the lowest id at it, the empty neighbours'
//! patches it carries), cleared, marked, picked, shared and applied each step in five dispatches, after the other force stages but buoyancy and before
//! `integrate`. Built only when the plan has the stage; its uniform and cells are made at upload
//! and bring nothing back (the pressure is the scene's, the platens are the core's walls). CPU
//! twin: `effects/confining_pressure/cpu.rs`.

use crate::backend::gpu::bindings::{Holder, Lane, DISP, FORCE, KIND, ORIGIN, PARAMS, WALLS};
use crate::backend::gpu::buffers::DeviceLanes;
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::confining_pressure::ConfiningPlan;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use wgsl as cp;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("confining_pressure");

    /// The pressure, the axis, the cells and the platens' wall indices (`Confine`).
    pub const CONFINE: Lane = lane(HOME, "confine", "Confine");
    /// Per cell: the largest reach's f32 bits, the lowest id at that reach, the patches of empty
    /// neighbours it carries.
    pub const CELLS: Lane = lane(HOME, "cells", "array<atomic<u32>>");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use super::wgsl as cp;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    pub const SHADER: Shader = Shader {
        name: "confining_pressure",
        source: include_str!("../../../../shaders/confining_pressure.wgsl"),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read(ORIGIN),
            read(DISP),
            read(KIND),
            read(WALLS),
            read_write(FORCE),
            uniform(cp::CONFINE),
            read_write(cp::CELLS),
        ]]),
    };
}

/// `Confine` in confining_pressure.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Confine {
    pressure: f32,
    cx: f32,
    cy: f32,
    bands: u32,
    sectors: u32,
    bottom: u32,
    top: u32,
    cells: u32,
    /// A 2D model's plate thickness (m; 0 in 3D), read behind the PLANAR constant.
    thickness: f32,
    pad: [u32; 3],
}

/// The stage's pipelines, one per entry point.
struct Pipelines {
    clear: Pipeline,
    mark: Pipeline,
    pick: Pipeline,
    share: Pipeline,
    apply: Pipeline,
}

fn pipelines(device: &GpuContext, constants: &[(&str, f64)]) -> Pipelines {
    let make = |entry| shaders::pipeline(device, Stage::ConfiningPressure.name(), &SHADER, entry, constants);
    Pipelines {
        clear: make("confine_clear"),
        mark: make("confine_mark"),
        pick: make("confine_pick"),
        share: make("confine_share"),
        apply: make("confine_apply"),
    }
}

/// The stage's uniform and cells on the device.
struct Lanes {
    confine: wgpu::Buffer,
    cells: wgpu::Buffer,
    pub bytes: u64,
}

impl Lanes {
    fn upload(ctx: &GpuContext, plan: &ConfiningPlan) -> Self {
        let cells = plan.bands * plan.sectors;
        let words = Confine {
            pressure: plan.pressure as f32,
            cx: plan.axis[0] as f32,
            cy: plan.axis[1] as f32,
            bands: plan.bands,
            sectors: plan.sectors,
            bottom: plan.bottom as u32,
            top: plan.top as u32,
            cells,
            thickness: plan.thickness.unwrap_or(0.0) as f32,
            pad: [0; 3],
        };
        let confine = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("confine"),
            contents: bytemuck::bytes_of(&words),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let size = 12 * u64::from(cells);
        let cells = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("membrane cells"),
            size,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Lanes { confine, cells, bytes: size + std::mem::size_of::<Confine>() as u64 }
    }
}

impl Holder for Lanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        match lane {
            cp::CONFINE => Some(&self.confine),
            cp::CELLS => Some(&self.cells),
            _ => None,
        }
    }
}

/// The pipelines bound to one upload, in the order a step dispatches them, and the bytes of the
/// stage's buffers.
struct Kernels {
    list: [Kernel; 5],
    bytes: u64,
}

fn kernels(device: &wgpu::Device, p: &Pipelines, d: &DeviceLanes, f: &Lanes) -> Result<Kernels> {
    // Each entry point's layout holds only the bindings it uses (the layout is the shader's).
    let place = [PARAMS, ORIGIN, DISP, KIND, WALLS, cp::CONFINE, cp::CELLS];
    let bind = |pipeline, lanes: &[Lane], groups| Kernel::bind_lanes(device, pipeline, lanes, &[d, f], groups);
    let cells = (f.cells.size() / 12) as usize;
    let list = [
        bind(&p.clear, &[cp::CONFINE, cp::CELLS], groups_for(cells))?,
        bind(&p.mark, &place, groups_for(d.n))?,
        bind(&p.pick, &place, groups_for(d.n))?,
        bind(&p.share, &[cp::CONFINE, cp::CELLS], groups_for(cells))?,
        bind(&p.apply, &[ORIGIN, DISP, WALLS, cp::CONFINE, cp::CELLS, FORCE], groups_for(cells))?,
    ];
    Ok(Kernels { list, bytes: f.bytes })
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`).
pub fn upload(_: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    let Some(c) = &u.plan.confining else { return Ok(None) };
    let lanes = Lanes::upload(u.ctx, c);
    Ok(Some(Box::new(kernels(&u.ctx.device, &pipelines(u.ctx, u.constants), u.lanes, &lanes)?)))
}

impl DeviceStage for Kernels {
    /// The step's five dispatches, in order.
    fn kernels(&self, _: u64) -> Vec<&Kernel> {
        self.list.iter().collect()
    }

    fn bytes(&self) -> u64 {
        self.bytes
    }
}
