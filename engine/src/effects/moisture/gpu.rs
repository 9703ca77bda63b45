//! The `moisture` stage on the GPU (shaders/diffusion.wgsl + shaders/moisture.wgsl): its
//! lanes, pipelines and the dispatch of one field step (per sub-step: `exchange` once per slab
//! of rows, then `settle`; then `shrink` with a radius table — `shrink_expand`, bound to the
//! conduction stage's temperatures and expansion lanes, when heat expands the elements too —
//! and `strengthen`, per slab, with a strength table). Built only when the plan has the stage; its buffers are made at upload and
//! the water contents and conductances (and radii, bond shares) come back at each download.
//! CPU twin: `cpu.rs` beside it.

use crate::backend::gpu::bindings::{Holder, Lane, DISP, ORIGIN, OTHER, PARAMS, ROW_LEN, SLAB, STATE};
use crate::backend::gpu::buffers::DeviceLanes;
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, DeviceStages, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::conduction::gpu::{wgsl as co, Field as Conduction};
use crate::effects::moisture::MoisturePlan;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use wgsl as mo;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("moisture");

    pub const FIELD: Lane = lane(HOME, "field", "Moisture");
    /// x water content ω, y capacity (the element's mass), z diffusivity α_w, w evaporation χ.
    pub const WATER: Lane = lane(HOME, "water", "array<vec4<f32>>");
    pub const NEXT: Lane = lane(HOME, "next", "array<f32>");
    pub const CONDUCTANCE: Lane = lane(HOME, "conductance", "array<f32>");
    pub const MODE: Lane = lane(HOME, "mode", "array<u32>");
    /// The ambient water content each element dries towards.
    pub const AMBIENT: Lane = lane(HOME, "ambient", "array<f32>");
    /// The radius r0 where the radius table's factor is 1.
    pub const RADIUS0: Lane = lane(HOME, "radius0", "array<f32>");
    /// (ω, value) points: the radius table's, then the strength table's.
    pub const TABLES: Lane = lane(HOME, "tables", "array<vec2<f32>>");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use super::wgsl as mo;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;
    use crate::effects::conduction::gpu::wgsl as co;

    /// The moisture stage: the diffusion core it shares (diffusion.wgsl), then its own file.
    pub const SHADER: Shader = Shader {
        name: "moisture",
        source: concat!(
            include_str!("../../../../shaders/periodic_image.wgsl"),
            "\n",
            include_str!("../../../../shaders/diffusion.wgsl"),
            "\n",
            include_str!("../../../../shaders/moisture.wgsl")
        ),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read_write(ORIGIN),
            read(DISP),
            read(ROW_LEN),
            read(OTHER),
            read_write(STATE),
            uniform(SLAB),
            uniform(mo::FIELD),
            read_write(mo::WATER),
            read_write(mo::NEXT),
            read_write(mo::CONDUCTANCE),
            read(mo::MODE),
            read(mo::AMBIENT),
            read(mo::RADIUS0),
            read(mo::TABLES),
            // With thermal expansion too (`shrink_expand` only): the conduction stage's
            // temperatures, and its (α, r0) whose r0 this stage keeps at r0·f(ω).
            read(co::THERMAL),
            read_write(co::EXPANSION),
        ]]),
    };
}

/// `Moisture` in moisture.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct FieldParams {
    dt: f32,
    bond_radius: f32,
    radius_points: u32,
    strength_points: u32,
    reference: f32,
    pad: [f32; 3],
}

/// The stage's pipelines.
struct Pipelines {
    exchange: Pipeline,
    settle: Pipeline,
    shrink: Option<Pipeline>,
    strengthen: Option<Pipeline>,
}

fn pipelines(device: &GpuContext, constants: &[(&str, f64)], plan: &MoisturePlan) -> Pipelines {
    let make = |entry| shaders::pipeline(device, Stage::Moisture.name(), &SHADER, entry, constants);
    Pipelines {
        exchange: make("exchange"),
        settle: make("settle"),
        shrink: plan
            .radius_table
            .is_some()
            .then(|| make(if plan.expansion.is_some() { "shrink_expand" } else { "shrink" })),
        strengthen: plan.strength_table.is_some().then(|| make("strengthen")),
    }
}

/// The stage's device lanes.
struct Lanes {
    params: wgpu::Buffer,
    /// (ω, m, α_w, χ) per particle.
    water: wgpu::Buffer,
    next: wgpu::Buffer,
    conductance: wgpu::Buffer,
    mode: wgpu::Buffer,
    ambient: wgpu::Buffer,
    /// r0 per particle; a placeholder without a radius table.
    radius0: wgpu::Buffer,
    /// The tables' points; a placeholder without tables.
    tables: wgpu::Buffer,
    /// Bytes of the lanes.
    bytes: u64,
}

impl Holder for Lanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        Some(match lane {
            mo::FIELD => &self.params,
            mo::WATER => &self.water,
            mo::NEXT => &self.next,
            mo::CONDUCTANCE => &self.conductance,
            mo::MODE => &self.mode,
            mo::AMBIENT => &self.ambient,
            mo::RADIUS0 => &self.radius0,
            mo::TABLES => &self.tables,
            _ => return None,
        })
    }
}

const STORAGE: wgpu::BufferUsages =
    wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST).union(wgpu::BufferUsages::COPY_SRC);

impl Lanes {
    /// The model's moisture lanes in f32 (the model's lanes must be fitted).
    fn upload(ctx: &GpuContext, m: &Model, plan: &MoisturePlan) -> Self {
        let w = &m.effects.moisture.lanes;
        let n = m.len();
        let mut bytes = 0u64;
        let mut make = |label: &str, data: &[u8]| {
            let zeros = [0u8; 128];
            let contents = if data.is_empty() { &zeros[..] } else { data };
            bytes += contents.len() as u64;
            ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: STORAGE,
            })
        };
        let water: Vec<[f32; 4]> = (0..n)
            .map(|i| [w.water[i] as f32, m.particles.mass[i] as f32, w.diffusivity[i] as f32, w.transfer[i] as f32])
            .collect();
        let mode: Vec<u32> = w.mode.iter().map(|&b| u32::from(b)).collect();
        let ambient: Vec<f32> = w.ambient.iter().map(|&a| a as f32).collect();
        let radius0: Vec<f32> =
            if plan.radius_table.is_some() { w.radius0.iter().map(|&r| r as f32).collect() } else { Vec::new() };
        let points = |t: &Option<crate::effects::moisture::physics::Table>| -> Vec<[f32; 2]> {
            t.as_ref().map_or_else(Vec::new, |t| t.points.iter().map(|&(x, y)| [x as f32, y as f32]).collect())
        };
        let (rp, sp) = (points(&plan.radius_table), points(&plan.strength_table));
        let params = FieldParams {
            dt: plan.substep(m.clock.dt) as f32,
            bond_radius: plan.bond_radius as f32,
            radius_points: rp.len() as u32,
            strength_points: sp.len() as u32,
            reference: plan.expansion.unwrap_or(0.0) as f32,
            pad: [0.0; 3],
        };
        let tables: Vec<[f32; 2]> = rp.into_iter().chain(sp).collect();
        Lanes {
            water: make("water", bytemuck::cast_slice(&water)),
            next: make("next water", &vec![0u8; 4 * n]),
            conductance: make("moisture conductance", &vec![0u8; 4 * n]),
            mode: make("moisture mode", bytemuck::cast_slice(&mode)),
            ambient: make("ambient water", bytemuck::cast_slice(&ambient)),
            radius0: make("radius0 (moisture)", bytemuck::cast_slice(&radius0)),
            tables: make("moisture tables", bytemuck::cast_slice(&tables)),
            params: ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("moisture"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            bytes,
        }
    }

    /// Brings the water contents and conductances back (and the radii, with a radius table,
    /// and the expansion's r0 when this stage keeps it; the bond shares come back with the
    /// pair states).
    fn download(
        &self,
        ctx: &GpuContext,
        d: &DeviceLanes,
        m: &mut Model,
        plan: &MoisturePlan,
        thermal: Option<&crate::effects::conduction::gpu::Lanes>,
    ) -> Result<()> {
        let n = d.n;
        let water: Vec<[f32; 4]> = crate::backend::gpu::buffers::read(ctx, &self.water, n)?;
        let g: Vec<f32> = crate::backend::gpu::buffers::read(ctx, &self.conductance, n)?;
        let w = &mut m.effects.moisture.lanes;
        for i in 0..n {
            w.water[i] = f64::from(water[i][0]);
            w.conductance[i] = f64::from(g[i]);
        }
        if plan.radius_table.is_some() {
            let origin: Vec<[f32; 4]> = crate::backend::gpu::buffers::read(ctx, &d.origin, n)?;
            for (r, o) in m.particles.radius.iter_mut().zip(&origin) {
                *r = f64::from(o[3]);
            }
        }
        if let (Some(_), Some(t)) = (plan.expansion, thermal) {
            let e: Vec<[f32; 2]> = crate::backend::gpu::buffers::read(ctx, t.expansion(), n)?;
            for (r0, e) in m.particles.thermal.radius0.iter_mut().zip(&e) {
                *r0 = f64::from(e[1]);
            }
        }
        Ok(())
    }
}

/// The pipelines bound to one upload.
struct Kernels {
    exchange: Vec<Kernel>,
    settle: Kernel,
    shrink: Option<Kernel>,
    strengthen: Vec<Kernel>,
}

/// `thermal`: the conduction stage's lanes, which `shrink_expand` reads (temperatures) and
/// writes (the expansion's r0) when the plan has thermal expansion too.
fn kernels(
    device: &wgpu::Device,
    p: &Pipelines,
    d: &DeviceLanes,
    f: &Lanes,
    plan: &MoisturePlan,
    thermal: Option<&crate::effects::conduction::gpu::Lanes>,
) -> Result<Kernels> {
    // Each entry point's layout holds only the bindings it uses (the layout is the shader's).
    // The rows' walk reads the scene's constants for a periodic cell's images only.
    let walk = [
        PARAMS,
        ORIGIN,
        DISP,
        ROW_LEN,
        OTHER,
        STATE,
        SLAB,
        mo::FIELD,
        mo::WATER,
        mo::NEXT,
        mo::CONDUCTANCE,
        mo::MODE,
        mo::AMBIENT,
    ];
    let exchange = d
        .slabs
        .iter()
        .map(|s| Kernel::bind_lanes(device, &p.exchange, &walk, &[d, s, f], groups_for(s.count)))
        .collect::<Result<_>>()?;
    let settle = Kernel::bind_lanes(device, &p.settle, &[PARAMS, mo::WATER, mo::NEXT], &[d, f], groups_for(d.n))?;
    let shrink = p
        .shrink
        .as_ref()
        .map(|k| {
            let mut lanes = vec![PARAMS, ORIGIN, mo::FIELD, mo::WATER, mo::RADIUS0, mo::TABLES];
            let mut holders: Vec<&dyn Holder> = vec![d, f];
            if let (Some(_), Some(t)) = (plan.expansion, thermal) {
                lanes.extend([co::THERMAL, co::EXPANSION]);
                holders.push(t);
            }
            Kernel::bind_lanes(device, k, &lanes, &holders, groups_for(d.n))
        })
        .transpose()?;
    let strengthen = match &p.strengthen {
        None => Vec::new(),
        Some(k) => {
            let lanes = [ROW_LEN, OTHER, STATE, SLAB, mo::FIELD, mo::WATER, mo::TABLES];
            d.slabs
                .iter()
                .map(|s| Kernel::bind_lanes(device, k, &lanes, &[d, s, f], groups_for(s.count)))
                .collect::<Result<_>>()?
        }
    };
    Ok(Kernels { exchange, settle, shrink, strengthen })
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`): the model's lanes,
/// fitted to the particles, and the kernels bound to them and, when heat expands the elements
/// too, to the conduction stage's lanes.
pub fn upload(m: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    let Some(plan) = &u.plan.moisture else { return Ok(None) };
    m.fit_moisture();
    let lanes = Lanes::upload(u.ctx, m, plan);
    let thermal = u.earlier.find::<Conduction>(Stage::Conduction).map(Conduction::lanes);
    let kernels = kernels(&u.ctx.device, &pipelines(u.ctx, u.constants, plan), u.lanes, &lanes, plan, thermal)?;
    Ok(Some(Box::new(Field { plan: plan.clone(), lanes, kernels })))
}

/// The stage on the device for one upload.
struct Field {
    plan: MoisturePlan,
    lanes: Lanes,
    kernels: Kernels,
}

impl DeviceStage for Field {
    /// One field step after each `every`-th step: per sub-step `exchange` once per slab of rows
    /// and `settle`, then the radii and the strengths from their tables.
    fn kernels(&self, step: u64) -> Vec<&Kernel> {
        if !self.plan.runs_after(step) {
            return Vec::new();
        }
        let k = &self.kernels;
        let substep = k.exchange.iter().chain([&k.settle]);
        let substeps = std::iter::repeat_n(substep, self.plan.substeps as usize).flatten();
        substeps.chain(&k.shrink).chain(&k.strengthen).collect()
    }

    fn bytes(&self) -> u64 {
        self.lanes.bytes
    }

    fn download(&self, ctx: &GpuContext, d: &DeviceLanes, m: &mut Model, stages: &DeviceStages) -> Result<()> {
        let thermal = stages.find::<Conduction>(Stage::Conduction).map(Conduction::lanes);
        self.lanes.download(ctx, d, m, &self.plan, thermal)
    }
}
