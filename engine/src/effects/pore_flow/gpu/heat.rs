//! The pore fluid's temperature on the GPU (shaders/pore_heat.wgsl, appended to
//! pore_flow.wgsl; f32): with the heat field and pore flow both on, the `pore_flow` stage's
//! thermal kernels — the equation of state with β_f·(T − T0), the heat the flow carries
//! (upwind), the regions that supply fluid at a temperature or hold their pores at one, and the
//! exchange with the grains at the pores' corners. Built only when the plan's pore flow is
//! `thermal` (its pipelines, lanes and kernels are absent otherwise); run inside the
//! `pore_flow` stage's debug group by [`super::PoreSession`]. CPU twin:
//! `effects/pore_flow/cpu/heat.rs` (`effects/pore_flow/fluid_temperature.rs`, and `effects/pore_flow/flow.rs`'s `substep` for the
//! advection).
//!
//! - **Upload**: each pore's excess temperature T − T0, what its region supplies (the
//!   temperature, whether it injects at it or holds the pore there), its mass less its excess
//!   mass (the device's mass is that plus the excess); each element's rounding carry (its f64
//!   temperature less the f32 one the conduction stage uploads). The first batch's exchange
//!   sub-steps come from the f64 state ([`PoreFlow::exchange_substeps_needed`], the guard's
//!   error when too many).
//! - **Between batches**: the next batch's exchange sub-steps from the batch's smallest
//!   stable exchange step (a counter), as for the flow.
//! - **Download**: the pores' temperatures, the heat each region supplied (c_f × a compensated
//!   f32 sum per pore, booked to its region), the elements' carries added to the temperatures
//!   the conduction stage brought back.

use super::lanes::{Lanes as FlowLanes, MASS_LANES, PRESSURE_LANES};
use crate::backend::gpu::bindings::{Holder, Lane, COUNTERS, DISP, ORIGIN};
use crate::backend::gpu::buffers::{read, storage_lane, DeviceLanes};
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::conduction::gpu as conduction;
use crate::effects::conduction::gpu::wgsl as co;
use crate::effects::pore_flow::flow::BoundaryKind;
use crate::effects::pore_flow::gpu::wgsl as pf;
use crate::effects::pore_flow::PoreFlow;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use wgsl as ph;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("pore_heat");

    pub const PARAMS: Lane = lane(HOME, "ph", "PoreHeat");
    /// Per pore: x the excess temperature its region supplies (K), y 1 when its flux region
    /// injects at it, z 1 when its fixed-pressure region holds it there, w its mass less its
    /// excess mass (kg; the mass is w + excess).
    pub const FLUID_BC: Lane = lane(HOME, "fluid_bc", "array<vec4<f32>>");
    pub const WARMTH: Lane = lane(HOME, "warmth", "array<f32>");
    pub const WARMTH_NEXT: Lane = lane(HOME, "warmth_next", "array<f32>");
    /// Per pore: Σ Δm·w its region supplied since the upload (kg·K, compensated), × c_f on
    /// download.
    pub const HEAT_SUPPLIED: Lane = lane(HOME, "heat_supplied", "array<vec2<f32>>");
    /// Per tetrahedron: the exchange conductance of each corner (W/K).
    pub const CORNER_G: Lane = lane(HOME, "corner_g", "array<vec4<f32>>");
    /// Per element: what its exchange updates rounded away (K).
    pub const CARRY: Lane = lane(HOME, "carry", "array<f32>");
    /// Per pore: what its temperature updates rounded away (K), paired with `warmth_next`.
    pub const WARMTH_CARRY: Lane = lane(HOME, "warmth_carry", "array<f32>");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use super::wgsl as ph;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;
    use crate::effects::conduction::gpu::wgsl as co;
    use crate::effects::pore_flow::gpu::shader::PORE_FLOW_BINDINGS;

    /// The pore fluid's temperature: pore_flow.wgsl (its bindings and helpers), then its own file.
    pub const SHADER: Shader = Shader {
        name: "pore_heat",
        source: concat!(
            include_str!("../../../../../shaders/pore_flow.wgsl"),
            "\n",
            include_str!("../../../../../shaders/pore_heat.wgsl")
        ),
        bindings: Bindings(&[
            PORE_FLOW_BINDINGS,
            &[
                uniform(ph::PARAMS),
                read(ph::FLUID_BC),
                read_write(ph::WARMTH),
                read_write(ph::WARMTH_NEXT),
                read_write(ph::HEAT_SUPPLIED),
                read_write(ph::CORNER_G),
                // The conduction stage's lanes: (T, C, k, P) and the mode of each element.
                read_write(co::THERMAL),
                read(co::THERMAL_MODE),
                read_write(ph::CARRY),
                read_write(ph::WARMTH_CARRY),
            ],
        ]),
    };
}

/// `PoreHeat` in pore_heat.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PoreHeatParams {
    specific_heat: f32,
    expansion: f32,
    reference: f32,
    h: f32,
    film: f32,
    tets: u32,
    pad: [f32; 2],
}

/// The thermal kernels' pipelines.
pub struct Pipelines {
    pressure: Pipeline,
    mass: Pipeline,
    conductance: Pipeline,
    pore_exchange: Pipeline,
    element_exchange: Pipeline,
    settle: Pipeline,
    eos: Pipeline,
}

pub fn pipelines(device: &GpuContext, constants: &[(&str, f64)]) -> Pipelines {
    let make = |entry| shaders::pipeline(device, Stage::PoreFlow.name(), &SHADER, entry, constants);
    Pipelines {
        pressure: make("pore_pressure_thermal"),
        mass: make("pore_mass_thermal"),
        conductance: make("exchange_conductance"),
        pore_exchange: make("pore_exchange"),
        element_exchange: make("element_exchange"),
        settle: make("pore_settle"),
        eos: make("pore_eos_thermal"),
    }
}

/// The fluid temperature's lanes on the device (pore_heat.wgsl's).
struct Lanes {
    params: wgpu::Buffer,
    fluid_bc: wgpu::Buffer,
    warmth: wgpu::Buffer,
    warmth_next: wgpu::Buffer,
    heat_supplied: wgpu::Buffer,
    corner_g: wgpu::Buffer,
    carry: wgpu::Buffer,
    warmth_carry: wgpu::Buffer,
}

impl Holder for Lanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        Some(match lane {
            ph::PARAMS => &self.params,
            ph::FLUID_BC => &self.fluid_bc,
            ph::WARMTH => &self.warmth,
            ph::WARMTH_NEXT => &self.warmth_next,
            ph::HEAT_SUPPLIED => &self.heat_supplied,
            ph::CORNER_G => &self.corner_g,
            ph::CARRY => &self.carry,
            ph::WARMTH_CARRY => &self.warmth_carry,
            _ => return None,
        })
    }
}

/// The fluid's temperature on the device for one upload: its lanes and kernels.
pub struct PoreHeatSession {
    lanes: Lanes,
    uniform: PoreHeatParams,
    pressure: Kernel,
    mass: Kernel,
    /// The exchange's kernels; none when Nu·k_f = 0 (nothing exchanges).
    exchange: Option<ExchangeKernels>,
    /// Exchange sub-steps per mechanical step in the current batch.
    pub exchange_substeps: u32,
    pores: usize,
    elements: usize,
    /// Bytes of the lanes.
    pub bytes: u64,
}

struct ExchangeKernels {
    conductance: Kernel,
    pore: Kernel,
    element: Kernel,
    settle: Kernel,
    eos: Kernel,
}

impl PoreHeatSession {
    /// Uploads the fluid's temperature of `f` (fitted to the model) with `exchange` sub-steps
    /// of the mechanical step, and binds the thermal kernels to the flow's lanes `l`, the
    /// core's `d` and the conduction stage's `c`. Refuses a lane larger than `limit` bytes.
    #[allow(clippy::too_many_arguments)]
    pub fn upload(
        ctx: &GpuContext,
        m: &Model,
        f: &PoreFlow,
        l: &FlowLanes,
        d: &DeviceLanes,
        c: &conduction::Lanes,
        p: &Pipelines,
        exchange: u32,
        limit: u64,
    ) -> Result<Self> {
        let np = f.network.pore_count();
        let n = m.len();
        let t0 = f.reference;
        let mut bytes = 0u64;
        let mut make = |lane: &'static str, data: &[u8]| storage_lane(ctx, lane, data, 32, limit, &mut bytes);
        let warmth: Vec<f32> = (0..np).map(|p| f.excess_temperature(p) as f32).collect();
        let fluid_bc: Vec<[f32; 4]> = (0..np)
            .map(|p| {
                let (mut supplied, mut injects) = (0.0, 0.0);
                if let Some(b) = f.boundaries.get(f.region[p] as usize) {
                    if let Some(t) = b.temperature {
                        supplied = (t - t0) as f32;
                        injects = if matches!(b.kind, BoundaryKind::Flux(_)) { 1.0 } else { 0.0 };
                    }
                }
                let holds = if f.fixed_temperature(p).is_some() { 1.0 } else { 0.0 };
                [supplied, injects, holds, (f.mass[p] - f64::from(l.excess0[p])) as f32]
            })
            .collect();
        let th = &m.particles.thermal;
        let carry: Vec<f32> = th.temperature.iter().map(|&t| (t - f64::from(t as f32)) as f32).collect();
        let h = f.fluid.heat;
        let film = 0.5 * h.nusselt * h.conductivity;
        let tets = f.network.tri.tets.len();
        let exchange = exchange.max(1);
        let uniform = PoreHeatParams {
            specific_heat: h.specific_heat as f32,
            expansion: h.expansion as f32,
            reference: t0 as f32,
            h: (m.clock.dt / f64::from(exchange)) as f32,
            film: film as f32,
            tets: tets as u32,
            pad: [0.0; 2],
        };
        let params = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("pore heat parameters"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let rest: Vec<f32> = (0..np).map(|p| (f.excess_temperature(p) - f64::from(warmth[p])) as f32).collect();
        let lanes = Lanes {
            params,
            fluid_bc: make("pore fluid supply", bytemuck::cast_slice(&fluid_bc))?,
            warmth: make("pore fluid temperature", bytemuck::cast_slice(&warmth))?,
            warmth_next: make("pore fluid next temperature", bytemuck::cast_slice(&warmth))?,
            heat_supplied: make("pore supplied heat", bytemuck::cast_slice(&vec![[0f32; 2]; np]))?,
            corner_g: make("exchange conductance", bytemuck::cast_slice(&vec![[0f32; 4]; tets]))?,
            carry: make("exchange carry", bytemuck::cast_slice(&carry))?,
            warmth_carry: make("pore fluid temperature carry", bytemuck::cast_slice(&rest))?,
        };
        // Each entry point binds only the lanes it uses (its layout is derived from the shader).
        let holders: [&dyn Holder; 4] = [d, l, c, &lanes];
        let bind = |pipeline: &Pipeline, used: &[Lane], n: usize| {
            Kernel::bind_lanes(&ctx.device, pipeline, used, &holders, groups_for(n))
        };
        // The flow's sub-step kernels, with the heat the flow carries.
        let carried = [ph::FLUID_BC, ph::WARMTH, ph::WARMTH_NEXT, ph::HEAT_SUPPLIED, ph::WARMTH_CARRY];
        let pressure = bind(&p.pressure, &[&PRESSURE_LANES[..], &[ph::PARAMS], &carried].concat(), np)?;
        let mass = bind(&p.mass, &[&MASS_LANES[..], &carried].concat(), np)?;
        let exchange_kernels = (film > 0.0).then(|| -> Result<ExchangeKernels> {
            let conductance = [ORIGIN, DISP, pf::TETS, ph::PARAMS, ph::CORNER_G, co::THERMAL, co::THERMAL_MODE];
            let pore = [
                pf::PARAMS,
                pf::TETS,
                pf::PORE_TET_START,
                pf::PORE_TETS,
                pf::EXCESS,
                COUNTERS,
                ph::PARAMS,
                ph::FLUID_BC,
                ph::WARMTH,
                ph::WARMTH_NEXT,
                ph::CORNER_G,
                co::THERMAL,
                ph::CARRY,
                ph::WARMTH_CARRY,
            ];
            let element = [
                pf::PARAMS,
                pf::TET_PORE,
                pf::ELEM_START,
                pf::ELEM_CORNERS,
                COUNTERS,
                ph::PARAMS,
                ph::WARMTH,
                ph::CORNER_G,
                co::THERMAL,
                co::THERMAL_MODE,
                ph::CARRY,
            ];
            let settle = [
                pf::PARAMS,
                pf::EXCESS,
                ph::FLUID_BC,
                ph::WARMTH,
                ph::WARMTH_NEXT,
                ph::HEAT_SUPPLIED,
                ph::WARMTH_CARRY,
            ];
            let eos = [
                pf::PARAMS,
                pf::VOLUME,
                pf::VOLUME0,
                pf::EXCESS,
                pf::PRESSURE,
                ph::PARAMS,
                ph::WARMTH,
                pf::VOLUME_HOST,
            ];
            Ok(ExchangeKernels {
                conductance: bind(&p.conductance, &conductance, tets)?,
                pore: bind(&p.pore_exchange, &pore, np)?,
                element: bind(&p.element_exchange, &element, n)?,
                settle: bind(&p.settle, &settle, np)?,
                eos: bind(&p.eos, &eos, np)?,
            })
        });
        Ok(PoreHeatSession {
            lanes,
            uniform,
            pressure,
            mass,
            exchange: exchange_kernels.transpose()?,
            exchange_substeps: exchange,
            pores: np,
            elements: n,
            bytes: bytes + std::mem::size_of::<PoreHeatParams>() as u64,
        })
    }

    /// Whether the fluid exchanges heat with the grains (Nu·k_f > 0).
    pub fn exchanges(&self) -> bool {
        self.exchange.is_some()
    }

    /// Sets the exchange sub-steps of the following mechanical steps of length `dt`.
    pub fn set_exchange_substeps(&mut self, ctx: &GpuContext, n: u32, dt: f64) {
        let n = n.max(1);
        if n != self.exchange_substeps {
            self.exchange_substeps = n;
            self.uniform.h = (dt / f64::from(n)) as f32;
            ctx.queue.write_buffer(&self.lanes.params, 0, bytemuck::bytes_of(&self.uniform));
        }
    }

    /// One flow sub-step: pressures (with the temperatures the last made current), then masses
    /// and the heat they carry.
    pub fn dispatch_substep(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.pressure.dispatch(pass);
        self.mass.dispatch(pass);
    }

    /// The pressures after the last sub-step.
    pub fn dispatch_pressure(&self, pass: &mut wgpu::ComputePass<'_>) {
        self.pressure.dispatch(pass);
    }

    /// The exchange with the grains for one mechanical step, then the pressures with the
    /// temperatures it left.
    pub fn dispatch_exchange(&self, pass: &mut wgpu::ComputePass<'_>) {
        let Some(x) = &self.exchange else { return };
        x.conductance.dispatch(pass);
        for _ in 0..self.exchange_substeps {
            x.pore.dispatch(pass);
            x.element.dispatch(pass);
            x.settle.dispatch(pass);
        }
        x.eos.dispatch(pass);
    }

    /// Brings the temperatures back: the pores' into `f` (and the heat each region supplied, to
    /// its books), the elements' carries onto the temperatures the conduction stage brought
    /// back into `m`.
    pub fn download(&self, ctx: &GpuContext, m: &mut Model, f: &mut PoreFlow) -> Result<()> {
        let w: Vec<f32> = read(ctx, &self.lanes.warmth, self.pores)?;
        let wc: Vec<f32> = read(ctx, &self.lanes.warmth_carry, self.pores)?;
        let s: Vec<[f32; 2]> = read(ctx, &self.lanes.heat_supplied, self.pores)?;
        let carry: Vec<f32> = read(ctx, &self.lanes.carry, self.elements)?;
        let c_f = f.fluid.heat.specific_heat;
        if f.temperature.len() == self.pores {
            for p in 0..self.pores {
                f.temperature[p] = f.reference + f64::from(w[p]) + f64::from(wc[p]);
                let booked = c_f * (f64::from(s[p][0]) + f64::from(s[p][1]));
                if booked != 0.0 {
                    if let Some(h) = f.region_heat.get_mut(f.region[p] as usize) {
                        *h += booked;
                    }
                }
            }
        }
        let th = &mut m.particles.thermal;
        if th.temperature.len() == self.elements {
            for (t, c) in th.temperature.iter_mut().zip(&carry) {
                *t += f64::from(*c);
            }
        }
        f.exchange_substeps = if self.exchanges() { self.exchange_substeps } else { 0 };
        Ok(())
    }
}
