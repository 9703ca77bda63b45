//! The `conduction` stage on the GPU (shaders/conduction.wgsl): its lanes, pipelines and the
//! dispatch of one field step (per sub-step: `conduct` once per slab of rows, then `settle`;
//! then `expand` when some element expands). Built only when the plan has the stage; its
//! buffers are made at upload and the temperatures, conductances (and radii, with expansion)
//! come back at each download. CPU twin: `effects/conduction/cpu.rs`.
//!
//! With the plan's `dissipation`, each field step first runs `feed`: the heat the device's
//! ledger ([`crate::effects::heat_ledger`]) booked on each element since the last field step goes into its
//! temperature. The ledger's device sums start at zero at each upload, so the `fed` lane
//! holds, as a compensated f32 pair, the device sum at the last feed less the heat the host
//! had booked but not fed at the upload; the download gives the model's `fed` lane back in
//! the host's terms (booked at the upload + the device's fed sum), so a run may continue on
//! either backend.

use crate::backend::gpu::bindings::{Holder, Lane, DISP, HEAT, ORIGIN, OTHER, PARAMS, ROW_LEN, SLAB, STATE};
use crate::backend::gpu::buffers::DeviceLanes;
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, DeviceStages, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::conduction::ConductionPlan;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use wgsl as co;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("conduction");

    pub const FIELD: Lane = lane(HOME, "field", "Conduction");
    /// x temperature, y capacity C = m·c, z conductivity k, w source (W).
    pub const THERMAL: Lane = lane(HOME, "thermal", "array<vec4<f32>>");
    pub const NEXT: Lane = lane(HOME, "next", "array<f32>");
    pub const CONDUCTANCE: Lane = lane(HOME, "conductance", "array<f32>");
    pub const MODE: Lane = lane(HOME, "mode", "array<u32>");
    /// [`MODE`]'s buffer as pore_heat.wgsl names it.
    pub const THERMAL_MODE: Lane = lane(HOME, "thermal_mode", "array<u32>");
    /// x expansion coefficient α, y radius r0 at T0.
    pub const EXPANSION: Lane = lane(HOME, "expansion", "array<vec2<f32>>");
    /// Per element, the ledger's booked heat (a compensated pair) at the last field step that
    /// fed it, less what the host had booked at the upload (its own part of the sum starts at
    /// zero).
    pub const FED: Lane = lane(HOME, "fed", "array<vec2<f32>>");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use super::wgsl as co;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    /// The conduction stage: the diffusion core it shares with moisture (diffusion.wgsl, no
    /// bindings of its own), then its own file.
    pub const SHADER: Shader = Shader {
        name: "conduction",
        source: concat!(
            include_str!("../../../../shaders/periodic_image.wgsl"),
            "\n",
            include_str!("../../../../shaders/diffusion.wgsl"),
            "\n",
            include_str!("../../../../shaders/conduction.wgsl")
        ),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read_write(ORIGIN),
            read(DISP),
            read(ROW_LEN),
            read(OTHER),
            read(STATE),
            uniform(SLAB),
            uniform(co::FIELD),
            read_write(co::THERMAL),
            read_write(co::NEXT),
            read_write(co::CONDUCTANCE),
            read(co::MODE),
            read(co::EXPANSION),
            // Read by `feed`.
            read(HEAT),
            read_write(co::FED),
        ]]),
    };
}

/// `Conduction` in conduction.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct FieldParams {
    dt: f32,
    bond_radius: f32,
    reference: f32,
    pad: f32,
}

/// The stage's pipelines.
struct Pipelines {
    conduct: Pipeline,
    settle: Pipeline,
    expand: Option<Pipeline>,
    /// Only when the dissipated heat is fed in.
    feed: Option<Pipeline>,
}

fn pipelines(device: &GpuContext, constants: &[(&str, f64)], plan: &ConductionPlan) -> Pipelines {
    let mut c = constants.to_vec();
    c.push(("EXPANSION", if plan.expansion { 1.0 } else { 0.0 }));
    let make = |entry| shaders::pipeline(device, Stage::Conduction.name(), &SHADER, entry, &c);
    Pipelines {
        conduct: make("conduct"),
        settle: make("settle"),
        expand: plan.expansion.then(|| make("expand")),
        feed: plan.dissipation.then(|| make("feed")),
    }
}

/// The stage's device lanes.
pub struct Lanes {
    params: wgpu::Buffer,
    /// (T, C, k, P) per particle.
    thermal: wgpu::Buffer,
    next: wgpu::Buffer,
    conductance: wgpu::Buffer,
    mode: wgpu::Buffer,
    /// (α, r0) per particle; a placeholder without expansion.
    expansion: wgpu::Buffer,
    /// The ledger's heat fed so far, in the device's terms (a compensated pair per particle);
    /// only when the dissipated heat is fed in.
    fed: Option<wgpu::Buffer>,
    /// Bytes of the lanes.
    bytes: u64,
}

impl Holder for Lanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        Some(match lane {
            co::FIELD => &self.params,
            co::THERMAL => &self.thermal,
            co::NEXT => &self.next,
            co::CONDUCTANCE => &self.conductance,
            co::MODE | co::THERMAL_MODE => &self.mode,
            co::EXPANSION => &self.expansion,
            co::FED => return self.fed.as_ref(),
            _ => return None,
        })
    }
}

const STORAGE: wgpu::BufferUsages =
    wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST).union(wgpu::BufferUsages::COPY_SRC);

impl Lanes {
    /// The model's thermal lanes in f32 (the model's lanes must be fitted).
    fn upload(ctx: &GpuContext, m: &Model, plan: &ConductionPlan) -> Self {
        let th = &m.particles.thermal;
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
        let thermal: Vec<[f32; 4]> = (0..n)
            .map(|i| [th.temperature[i] as f32, th.capacity[i] as f32, th.conductivity[i] as f32, th.source[i] as f32])
            .collect();
        let mode: Vec<u32> = th.mode.iter().map(|&b| u32::from(b)).collect();
        let expansion: Vec<[f32; 2]> = if plan.expansion {
            (0..n).map(|i| [th.expansion[i] as f32, th.radius0[i] as f32]).collect()
        } else {
            Vec::new()
        };
        // The device's ledger starts at zero: what the host booked and has not fed is owed.
        let fed: Vec<[f32; 2]> = if plan.dissipation {
            (0..n)
                .map(|i| {
                    let owed = th.fed[i] - m.booked_heat(i);
                    let hi = owed as f32;
                    [hi, (owed - f64::from(hi)) as f32]
                })
                .collect()
        } else {
            Vec::new()
        };
        let params = FieldParams {
            dt: plan.substep(m.clock.dt) as f32,
            bond_radius: plan.bond_radius as f32,
            reference: plan.reference as f32,
            pad: 0.0,
        };
        Lanes {
            thermal: make("temperature", bytemuck::cast_slice(&thermal)),
            next: make("next temperature", &vec![0u8; 4 * n]),
            conductance: make("conductance", &vec![0u8; 4 * n]),
            mode: make("thermal mode", bytemuck::cast_slice(&mode)),
            expansion: make("expansion", bytemuck::cast_slice(&expansion)),
            fed: plan.dissipation.then(|| make("fed heat", bytemuck::cast_slice(&fed))),
            params: ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("conduction"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            bytes,
        }
    }

    /// The (α, r0) lane (a placeholder without expansion), whose r0 the moisture stage keeps
    /// at r0·f(ω) when both set the radius.
    pub fn expansion(&self) -> &wgpu::Buffer {
        &self.expansion
    }

    /// Brings the temperatures and conductances back (and the radii, with expansion, and the
    /// heat fed, with dissipation). Runs before the heat ledger's download adds the device's
    /// sums to the model's ledger.
    fn download(&self, ctx: &GpuContext, d: &DeviceLanes, m: &mut Model, plan: &ConductionPlan) -> Result<()> {
        let n = d.n;
        let thermal: Vec<[f32; 4]> = crate::backend::gpu::buffers::read(ctx, &self.thermal, n)?;
        let g: Vec<f32> = crate::backend::gpu::buffers::read(ctx, &self.conductance, n)?;
        if let Some(fed) = &self.fed {
            let fed: Vec<[f32; 2]> = crate::backend::gpu::buffers::read(ctx, fed, n)?;
            let booked: Vec<f64> = (0..n).map(|i| m.booked_heat(i)).collect();
            for (i, f) in m.particles.thermal.fed.iter_mut().enumerate() {
                *f = booked[i] + f64::from(fed[i][0]) + f64::from(fed[i][1]);
            }
        }
        let th = &mut m.particles.thermal;
        for i in 0..n {
            th.temperature[i] = f64::from(thermal[i][0]);
            th.conductance[i] = f64::from(g[i]);
        }
        if plan.expansion {
            let origin: Vec<[f32; 4]> = crate::backend::gpu::buffers::read(ctx, &d.origin, n)?;
            for (r, o) in m.particles.radius.iter_mut().zip(&origin) {
                *r = f64::from(o[3]);
            }
        }
        Ok(())
    }
}

/// The pipelines bound to one upload.
struct Kernels {
    conduct: Vec<Kernel>,
    settle: Kernel,
    expand: Option<Kernel>,
    feed: Option<Kernel>,
}

fn kernels(device: &wgpu::Device, p: &Pipelines, d: &DeviceLanes, f: &Lanes) -> Result<Kernels> {
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
        co::FIELD,
        co::THERMAL,
        co::NEXT,
        co::CONDUCTANCE,
        co::MODE,
    ];
    let conduct = d
        .slabs
        .iter()
        .map(|s| Kernel::bind_lanes(device, &p.conduct, &walk, &[d, s, f], groups_for(s.count)))
        .collect::<Result<_>>()?;
    let settle = Kernel::bind_lanes(device, &p.settle, &[PARAMS, co::THERMAL, co::NEXT], &[d, f], groups_for(d.n))?;
    let expand = p
        .expand
        .as_ref()
        .map(|e| {
            let lanes = [PARAMS, ORIGIN, co::FIELD, co::THERMAL, co::EXPANSION];
            Kernel::bind_lanes(device, e, &lanes, &[d, f], groups_for(d.n))
        })
        .transpose()?;
    let feed = p
        .feed
        .as_ref()
        .map(|k| {
            let lanes = [PARAMS, co::THERMAL, co::MODE, HEAT, co::FED];
            Kernel::bind_lanes(device, k, &lanes, &[d, f], groups_for(d.n))
        })
        .transpose()?;
    Ok(Kernels { conduct, settle, expand, feed })
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`): the model's lanes,
/// fitted to the particles, and the kernels bound to them.
pub fn upload(m: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    let Some(plan) = u.plan.conduction else { return Ok(None) };
    m.fit_thermal();
    let lanes = Lanes::upload(u.ctx, m, &plan);
    let kernels = kernels(&u.ctx.device, &pipelines(u.ctx, u.constants, &plan), u.lanes, &lanes)?;
    Ok(Some(Box::new(Field { plan, lanes, kernels })))
}

/// The stage on the device for one upload.
pub struct Field {
    plan: ConductionPlan,
    lanes: Lanes,
    kernels: Kernels,
}

impl Field {
    /// The stage's lanes, which the moisture and pore_flow stages bind beside their own.
    pub fn lanes(&self) -> &Lanes {
        &self.lanes
    }
}

impl DeviceStage for Field {
    /// One field step after each `every`-th step: the heat fed in, then per sub-step `conduct`
    /// once per slab of rows and `settle`, then the expansion.
    fn kernels(&self, step: u64) -> Vec<&Kernel> {
        if !self.plan.runs_after(step) {
            return Vec::new();
        }
        let k = &self.kernels;
        let substep = k.conduct.iter().chain([&k.settle]);
        let substeps = std::iter::repeat_n(substep, self.plan.substeps as usize).flatten();
        k.feed.iter().chain(substeps).chain(&k.expand).collect()
    }

    fn bytes(&self) -> u64 {
        self.lanes.bytes
    }

    fn download(&self, ctx: &GpuContext, d: &DeviceLanes, m: &mut Model, _: &DeviceStages) -> Result<()> {
        self.lanes.download(ctx, d, m, &self.plan)
    }

    /// The heat fed since the upload (the `fed` lane, in the device's terms).
    fn keeps_sums(&self) -> bool {
        true
    }
}
