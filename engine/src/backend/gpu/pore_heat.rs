//! The pore fluid's temperature on the GPU (shaders/pore_heat.wgsl, appended to
//! pore_flow.wgsl; f32): with the heat field and pore flow both on, the `pore_flow` stage's
//! thermal kernels — the equation of state with β_f·(T − T0), the heat the flow carries
//! (upwind), the regions that supply fluid at a temperature or hold their pores at one, and the
//! exchange with the grains at the pores' corners. Built only when the plan's pore flow is
//! `thermal` (its pipelines, lanes and kernels are absent otherwise); run inside the
//! `pore_flow` stage's debug group by [`super::pore_flow::PoreSession`]. CPU twin:
//! `backend/cpu/pore_heat.rs` (`pores/heat.rs`, and `pores/flow.rs`'s `substep` for the
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

use super::buffers::{read, storage_lane, DeviceLanes};
use super::conduction;
use super::device::GpuContext;
use super::pore_flow::Lanes as FlowLanes;
use super::shaders::{self, groups_for, Kernel};
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use crate::pores::flow::BoundaryKind;
use crate::pores::PoreFlow;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

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
    pressure: wgpu::ComputePipeline,
    mass: wgpu::ComputePipeline,
    conductance: wgpu::ComputePipeline,
    pore_exchange: wgpu::ComputePipeline,
    element_exchange: wgpu::ComputePipeline,
    settle: wgpu::ComputePipeline,
    eos: wgpu::ComputePipeline,
}

pub fn pipelines(device: &GpuContext, constants: &[(&str, f64)]) -> Pipelines {
    let make = |entry| shaders::pipeline(device, Stage::PoreFlow.name(), shaders::PORE_HEAT, entry, constants);
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

/// The fluid's temperature on the device for one upload: its lanes and kernels.
pub struct PoreHeatSession {
    params: wgpu::Buffer,
    uniform: PoreHeatParams,
    warmth: wgpu::Buffer,
    warmth_carry: wgpu::Buffer,
    heat_supplied: wgpu::Buffer,
    carry: wgpu::Buffer,
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
        let fluid_bc = make("pore fluid supply", bytemuck::cast_slice(&fluid_bc))?;
        let warmth_lane = make("pore fluid temperature", bytemuck::cast_slice(&warmth))?;
        let warmth_next = make("pore fluid next temperature", bytemuck::cast_slice(&warmth))?;
        let heat_supplied = make("pore supplied heat", bytemuck::cast_slice(&vec![[0f32; 2]; np]))?;
        let corner_g = make("exchange conductance", bytemuck::cast_slice(&vec![[0f32; 4]; tets]))?;
        let carry_lane = make("exchange carry", bytemuck::cast_slice(&carry))?;
        let rest: Vec<f32> = (0..np).map(|p| (f.excess_temperature(p) - f64::from(warmth[p])) as f32).collect();
        let warmth_carry = make("pore fluid temperature carry", bytemuck::cast_slice(&rest))?;
        let device = &ctx.device;
        let (thermal, mode) = (c.thermal(), c.mode());
        let pressure = Kernel::bind_at(
            device,
            &p.pressure,
            &[
                (1, &l.params),
                (9, &l.volume),
                (10, &l.volume0),
                (12, &l.excess),
                (13, &l.pressure),
                (14, &l.boundary),
                (15, &l.supplied),
                (31, &params),
                (32, &fluid_bc),
                (33, &warmth_lane),
                (34, &warmth_next),
                (35, &heat_supplied),
                (40, &warmth_carry),
                (41, &l.excess_carry),
                (42, &l.volume_host),
            ],
            groups_for(np),
        );
        let mass = Kernel::bind_at(
            device,
            &p.mass,
            &[
                (1, &l.params),
                (12, &l.excess),
                (13, &l.pressure),
                (14, &l.boundary),
                (15, &l.supplied),
                (16, &l.row_start),
                (17, &l.row),
                (18, &l.throats),
                (19, &l.conductance),
                (32, &fluid_bc),
                (33, &warmth_lane),
                (34, &warmth_next),
                (35, &heat_supplied),
                (40, &warmth_carry),
                (41, &l.excess_carry),
            ],
            groups_for(np),
        );
        let exchange_kernels = (film > 0.0).then(|| ExchangeKernels {
            conductance: Kernel::bind_at(
                device,
                &p.conductance,
                &[
                    (2, &d.origin),
                    (3, &d.disp),
                    (4, &l.tets),
                    (31, &params),
                    (36, &corner_g),
                    (37, thermal),
                    (38, mode),
                ],
                groups_for(tets),
            ),
            pore: Kernel::bind_at(
                device,
                &p.pore_exchange,
                &[
                    (1, &l.params),
                    (4, &l.tets),
                    (7, &l.pore_tet_start),
                    (8, &l.pore_tets),
                    (12, &l.excess),
                    (25, &d.counters),
                    (31, &params),
                    (32, &fluid_bc),
                    (33, &warmth_lane),
                    (34, &warmth_next),
                    (36, &corner_g),
                    (37, thermal),
                    (39, &carry_lane),
                    (40, &warmth_carry),
                ],
                groups_for(np),
            ),
            element: Kernel::bind_at(
                device,
                &p.element_exchange,
                &[
                    (1, &l.params),
                    (5, &l.tet_pore),
                    (22, &l.elem_start),
                    (23, &l.elem_corners),
                    (25, &d.counters),
                    (31, &params),
                    (33, &warmth_lane),
                    (36, &corner_g),
                    (37, thermal),
                    (38, mode),
                    (39, &carry_lane),
                ],
                groups_for(n),
            ),
            settle: Kernel::bind_at(
                device,
                &p.settle,
                &[
                    (1, &l.params),
                    (12, &l.excess),
                    (32, &fluid_bc),
                    (33, &warmth_lane),
                    (34, &warmth_next),
                    (35, &heat_supplied),
                    (40, &warmth_carry),
                ],
                groups_for(np),
            ),
            eos: Kernel::bind_at(
                device,
                &p.eos,
                &[
                    (1, &l.params),
                    (9, &l.volume),
                    (10, &l.volume0),
                    (12, &l.excess),
                    (13, &l.pressure),
                    (31, &params),
                    (33, &warmth_lane),
                    (42, &l.volume_host),
                ],
                groups_for(np),
            ),
        });
        Ok(PoreHeatSession {
            params,
            uniform,
            warmth: warmth_lane,
            warmth_carry,
            heat_supplied,
            carry: carry_lane,
            pressure,
            mass,
            exchange: exchange_kernels,
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
            ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&self.uniform));
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
        let w: Vec<f32> = read(ctx, &self.warmth, self.pores)?;
        let wc: Vec<f32> = read(ctx, &self.warmth_carry, self.pores)?;
        let s: Vec<[f32; 2]> = read(ctx, &self.heat_supplied, self.pores)?;
        let carry: Vec<f32> = read(ctx, &self.carry, self.elements)?;
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
