//! The `pore_flow` stage on the GPU (shaders/pore_flow.wgsl, f32), a force stage between
//! `rolling_resistance` (or `wall_forces`) and `integrate`: the pipelines, the stage's own
//! buffers (the network's topology, per-pore and per-throat lanes) and the kernels bound to
//! them and to the particles' lanes. Built only when the plan has the stage. CPU twin:
//! `effects/pore_flow/cpu/mod.rs`.
//!
//! Who does what:
//!
//! - **Host, at each upload** ([`PoreSession::upload`]): the network follows the elements as on
//!   the CPU ([`PoreFlow::follow`]: rebuilt, fluid carried over, after a drift of
//!   `rebuild_drift` × the mean radius or a change of the element count), the sub-steps of the
//!   first batch are sized from the f64 state ([`PoreFlow::substeps_needed`], the guard's error
//!   when too many), and the topology goes up: tetrahedra, pores, throats with their face's
//!   corners and bonded edges, each element's corners (the CSR row the forces gather over).
//! - **Device, each step**: bonds still holding across each throat's face, pore volumes and
//!   centres from the current positions, throat conductances, the stable flow step (its
//!   minimum over the batch into a counter), the flow's sub-steps, the pressures, and each
//!   element's pressure force added to its force lane; once per batch, the elements' drift
//!   since the network's build.
//! - **Host, between batches** (`GpuBackend::run_chunk`): the next batch's sub-steps from the
//!   batch's smallest stable step; when the drift may reach the rebuild threshold within the
//!   next step, the model comes back, the host rebuilds the network and puts it back up (the
//!   cost of a rebuild is a download and an upload of the model, as for rows built on the host).
//! - **Host, at each download** ([`PoreSession::download`]): the masses (the f64 mass at the
//!   upload plus the f32 change), the mass each boundary region supplied, the geometry in f64.
//!
//! With the heat field on too (the plan's pore flow `thermal`), the fluid's temperature runs in
//! the same step ([`heat`], shaders/pore_heat.wgsl): its pressure and mass kernels
//! take the place of `pore_pressure` and `pore_mass`, and the exchange with the grains runs
//! after the flow, before the pressure forces.
//!
//! The flow update alone is also driven by [`PoreFlowKernel`] (upload a network, run sub-steps,
//! download the masses), for the flow's own parity test.

pub mod heat;
pub mod lanes;

use crate::backend::gpu::bindings::{Lane, COUNTERS, DISP, FORCE, ORIGIN, OTHER, ROW_LEN, SLAB, STATE};
use crate::backend::gpu::buffers::{DeviceLanes, HostLanes};
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::conduction::gpu as conduction;
use crate::effects::pore_flow::PoreFlow;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use heat::{self as pore_heat, PoreHeatSession};
use lanes::{Lanes, MASS_LANES, PRESSURE_LANES};

use wgsl as pf;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    const HOME: Home = Home::Effect("pore_flow");

    pub const PARAMS: Lane = lane(HOME, "pp", "PoreParams");
    /// The four corners of each tetrahedron, its pore, and its orientation at the build (±1).
    pub const TETS: Lane = lane(HOME, "tets", "array<vec4<u32>>");
    pub const TET_PORE: Lane = lane(HOME, "tet_pore", "array<u32>");
    pub const TET_SIGN: Lane = lane(HOME, "tet_sign", "array<f32>");
    /// Tetrahedra of each pore (CSR).
    pub const PORE_TET_START: Lane = lane(HOME, "pore_tet_start", "array<u32>");
    pub const PORE_TETS: Lane = lane(HOME, "pore_tets", "array<u32>");
    pub const VOLUME: Lane = lane(HOME, "volume", "array<f32>");
    /// The volume at the upload, as pore_geometry measured it.
    pub const VOLUME0: Lane = lane(HOME, "volume0", "array<f32>");
    pub const CENTRE: Lane = lane(HOME, "centre", "array<vec4<f32>>");
    pub const EXCESS: Lane = lane(HOME, "excess", "array<f32>");
    pub const PRESSURE: Lane = lane(HOME, "pressure", "array<f32>");
    /// Per pore: (fixed pressure, volumetric source, 1 when held at the pressure else 0, 0).
    pub const BOUNDARY: Lane = lane(HOME, "boundary", "array<vec4<f32>>");
    /// Per pore: the mass its boundary region supplied since the upload (compensated sum).
    pub const SUPPLIED: Lane = lane(HOME, "supplied", "array<vec2<f32>>");
    /// Throats of each pore (CSR rows, each throat in both of its pores' rows).
    pub const ROW_START: Lane = lane(HOME, "row_start", "array<u32>");
    pub const ROW: Lane = lane(HOME, "row", "array<u32>");
    pub const THROATS: Lane = lane(HOME, "throats", "array<Throat>");
    pub const CONDUCTANCE: Lane = lane(HOME, "conductance", "array<f32>");
    /// The bonds across throats' faces at the build, (i, j), and whether each still holds.
    pub const BOND_EDGES: Lane = lane(HOME, "bond_edges", "array<vec2<u32>>");
    pub const BOND_ALIVE: Lane = lane(HOME, "bond_alive", "array<u32>");
    /// Each element's corners of tetrahedra (CSR), each 4·tet + corner, in tetrahedron order.
    pub const ELEM_START: Lane = lane(HOME, "elem_start", "array<u32>");
    pub const ELEM_CORNERS: Lane = lane(HOME, "elem_corners", "array<u32>");
    /// Each element's position at the network's build, less its origin.
    pub const PORE_BUILT: Lane = lane(HOME, "pore_built", "array<vec4<f32>>");
    /// Per pore: what its excess mass updates rounded away (kg).
    pub const EXCESS_CARRY: Lane = lane(HOME, "excess_carry", "array<f32>");
    /// Per pore: the host's (f64) volume at the upload, rounded to f32.
    pub const VOLUME_HOST: Lane = lane(HOME, "volume_host", "array<f32>");
}

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

pub(crate) mod shader {
    use super::wgsl as pf;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    /// pore_flow.wgsl's bindings, the first of the thermal stage's too.
    pub(crate) const PORE_FLOW_BINDINGS: &[Binding] = &[
        uniform(PARAMS),
        uniform(pf::PARAMS),
        read(ORIGIN),
        read(DISP),
        read(pf::TETS),
        read(pf::TET_PORE),
        read(pf::TET_SIGN),
        read(pf::PORE_TET_START),
        read(pf::PORE_TETS),
        read_write(pf::VOLUME),
        read_write(pf::VOLUME0),
        read_write(pf::CENTRE),
        read_write(pf::EXCESS),
        read_write(pf::PRESSURE),
        read(pf::BOUNDARY),
        read_write(pf::SUPPLIED),
        read(pf::ROW_START),
        read(pf::ROW),
        read(pf::THROATS),
        read_write(pf::CONDUCTANCE),
        read(pf::BOND_EDGES),
        read_write(pf::BOND_ALIVE),
        read(pf::ELEM_START),
        read(pf::ELEM_CORNERS),
        read_write(FORCE),
        read_write(COUNTERS),
        read(pf::PORE_BUILT),
        uniform(SLAB),
        read(ROW_LEN),
        read(OTHER),
        read(STATE),
        read_write(pf::EXCESS_CARRY),
        read(pf::VOLUME_HOST),
    ];

    pub const SHADER: Shader = Shader {
        name: "pore_flow",
        source: include_str!("../../../../../shaders/pore_flow.wgsl"),
        bindings: Bindings(&[PORE_FLOW_BINDINGS]),
    };
}

/// The stage's pipelines, one per entry point of pore_flow.wgsl.
pub struct Pipelines {
    bonds: Pipeline,
    geometry: Pipeline,
    conductance: Pipeline,
    stable_step: Pipeline,
    pressure: Pipeline,
    mass: Pipeline,
    forces: Pipeline,
    drift: Pipeline,
    /// The fluid's temperature, only when the plan's pore flow is `thermal`.
    heat: Option<pore_heat::Pipelines>,
}

fn pipeline(device: &GpuContext, entry: &str, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, Stage::PoreFlow.name(), &SHADER, entry, constants)
}

/// The stage's pipelines; with `thermal`, the fluid temperature's too (shaders/pore_heat.wgsl).
pub fn pipelines(device: &GpuContext, constants: &[(&str, f64)], thermal: bool) -> Pipelines {
    Pipelines {
        bonds: pipeline(device, "pore_bonds", constants),
        geometry: pipeline(device, "pore_geometry", constants),
        conductance: pipeline(device, "throat_conductance", constants),
        stable_step: pipeline(device, "pore_stable_step", constants),
        pressure: pipeline(device, "pore_pressure", constants),
        mass: pipeline(device, "pore_mass", constants),
        forces: pipeline(device, "pore_forces", constants),
        drift: pipeline(device, "pore_drift", constants),
        heat: thermal.then(|| pore_heat::pipelines(device, constants)),
    }
}

/// The stage's kernels bound to one upload (the bond checks one per slab of rows; none when
/// no bond crosses a throat's face).
pub struct Kernels {
    bonds: Vec<Kernel>,
    geometry: Kernel,
    conductance: Kernel,
    stable_step: Kernel,
    pressure: Kernel,
    mass: Kernel,
    forces: Kernel,
    drift: Kernel,
}

/// The stage on the device for one upload: its lanes, kernels and the batch's sub-steps.
pub struct PoreSession {
    lanes: Lanes,
    kernels: Kernels,
    /// The fluid's temperature, when the plan's pore flow is `thermal`.
    heat: Option<PoreHeatSession>,
    /// Flow sub-steps per mechanical step in the current batch.
    pub substeps: u32,
    /// Drift (m) at which the CPU would rebuild the network.
    pub drift_limit: f64,
    pub max_substeps: u32,
    pub bytes: u64,
    /// Whether a step has run since the upload (the device's geometry is then the stage's).
    pub stepped: bool,
}

impl PoreSession {
    /// The host's part of the step (the network follows the elements; the first batch's
    /// sub-steps; with `thermal`, the conduction stage's lanes, the fluid's temperatures fitted
    /// and the first batch's exchange sub-steps), then the upload of the network and its fluid,
    /// and the pore volumes at the upload measured on the device.
    pub fn upload(
        ctx: &GpuContext,
        m: &mut Model,
        host: &HostLanes,
        d: &DeviceLanes,
        p: &Pipelines,
        thermal: Option<&conduction::Lanes>,
        limit: u64,
    ) -> Result<Self> {
        let Some(mut f) = m.pores.take() else {
            return Err(crate::Error::InvalidScene("the plan has pore flow but the model has no pore network".into()));
        };
        let thermal = thermal.zip(p.heat.as_ref());
        if thermal.is_some() {
            m.fit_thermal();
            f.fit_temperature(m);
        }
        let mut prepared = Ok(0);
        if f.network.tri.points.len() != m.len() {
            prepared = f.rebuild(m).map(|_| 0);
        }
        if prepared.is_ok() {
            prepared = f.follow(m).and_then(|_| f.substeps_needed(m, m.clock.dt));
        }
        let mut exchange = Ok(0);
        if prepared.is_ok() && thermal.is_some() {
            exchange = f.exchange_substeps_needed(m, m.clock.dt);
        }
        let (n, exchange) = match (prepared, exchange) {
            (Ok(n), Ok(x)) => (n, x),
            (Err(e), _) | (_, Err(e)) => {
                m.pores = Some(f);
                return Err(e);
            }
        };
        let built: Vec<[f32; 4]> = f
            .network
            .built_at
            .iter()
            .zip(&host.origin)
            .map(|(b, o)| {
                [(b.x - f64::from(o[0])) as f32, (b.y - f64::from(o[1])) as f32, (b.z - f64::from(o[2])) as f32, 0.0]
            })
            .collect();
        let drift_limit = f.fluid.rebuild_drift * m.mean_radius();
        let max_substeps = f.fluid.max_substeps;
        let factors = f.network.throat_factors(m, &f.fluid);
        let lanes = Lanes::upload(ctx, &f, &built, &factors, m.clock.dt / f64::from(n), limit);
        let heat = match (&lanes, thermal) {
            (Ok(l), Some((c, hp))) => Some(PoreHeatSession::upload(ctx, m, &f, l, d, c, hp, exchange, limit)),
            _ => None,
        };
        m.pores = Some(f);
        let lanes = lanes?;
        let heat = heat.transpose()?;
        let kernels = kernels(&ctx.device, p, &lanes, d)?;
        // The volumes at the upload as the device measures them (the pressures see only their change).
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let label = Some("pore_flow: volumes at upload");
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label, timestamp_writes: None });
            kernels.geometry.dispatch(&mut pass);
        }
        let bytes = (lanes.mass0.len() * 4) as u64;
        enc.copy_buffer_to_buffer(&lanes.volume, 0, &lanes.volume0, 0, bytes);
        ctx.submit(enc);
        let bytes = lanes.bytes + heat.as_ref().map_or(0, |h| h.bytes);
        Ok(PoreSession { lanes, kernels, heat, substeps: n, drift_limit, max_substeps, bytes, stepped: false })
    }

    /// Sets the sub-steps of the following mechanical steps of length `dt`.
    pub fn set_substeps(&mut self, ctx: &GpuContext, n: u32, dt: f64) {
        if n != self.substeps {
            self.substeps = n;
            self.lanes.set_substep(ctx, dt / f64::from(n));
        }
    }

    /// The exchange sub-steps of the current batch, when the fluid exchanges heat with the
    /// grains on the device.
    pub fn exchange_substeps(&self) -> Option<u32> {
        self.heat.as_ref().filter(|h| h.exchanges()).map(|h| h.exchange_substeps)
    }

    /// Sets the exchange sub-steps of the following mechanical steps of length `dt`.
    pub fn set_exchange_substeps(&mut self, ctx: &GpuContext, n: u32, dt: f64) {
        if let Some(h) = self.heat.as_mut() {
            h.set_exchange_substeps(ctx, n, dt);
        }
    }

    /// Encodes one step of the stage (in a debug group named for it).
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        let k = &self.kernels;
        pass.push_debug_group(Stage::PoreFlow.name());
        for b in &k.bonds {
            b.dispatch(pass);
        }
        k.geometry.dispatch(pass);
        k.conductance.dispatch(pass);
        k.stable_step.dispatch(pass);
        match &self.heat {
            None => {
                for _ in 0..self.substeps {
                    k.pressure.dispatch(pass);
                    k.mass.dispatch(pass);
                }
                k.pressure.dispatch(pass);
            }
            Some(h) => {
                for _ in 0..self.substeps {
                    h.dispatch_substep(pass);
                }
                h.dispatch_pressure(pass);
                h.dispatch_exchange(pass);
            }
        }
        k.forces.dispatch(pass);
        pass.pop_debug_group();
    }

    /// Encodes the drift measure (once per batch).
    pub fn dispatch_drift(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.push_debug_group(Stage::PoreFlow.name());
        self.kernels.drift.dispatch(pass);
        pass.pop_debug_group();
    }

    /// Brings the fluid back into the model (whose positions, and temperatures with heat on,
    /// have come back already), the network's geometry recomputed in f64 from them.
    pub fn download(&self, ctx: &GpuContext, m: &mut Model) -> Result<()> {
        let Some(mut f) = m.pores.take() else { return Ok(()) };
        // Openings and crack flags at the positions that came back; then the stage's own
        // volumes, centres and conductances from the device.
        f.network.refresh(m, &f.fluid);
        let mut r = Ok(());
        if let Some(h) = &self.heat {
            r = h.download(ctx, m, &mut f);
        }
        let r = r.and_then(|_| self.lanes.download(ctx, &mut f, self.stepped));
        f.substeps = self.substeps;
        m.pores = Some(f);
        r
    }
}

fn kernels(device: &wgpu::Device, p: &Pipelines, l: &Lanes, d: &DeviceLanes) -> Result<Kernels> {
    let (np, nt, ne) = (l.uniform.pores as usize, l.uniform.throats as usize, l.uniform.elements as usize);
    // Each entry point binds only the lanes it uses (its layout is derived from the shader).
    let bind = |pipeline: &Pipeline, used: &[Lane], n: usize| {
        Kernel::bind_lanes(device, pipeline, used, &[d, l], groups_for(n))
    };
    let bonds = if l.uniform.bond_edges == 0 {
        Vec::new()
    } else {
        let groups = groups_for(l.uniform.bond_edges as usize);
        // No scene constant: the rows' walk needs none.
        let lanes = [pf::PARAMS, pf::BOND_EDGES, pf::BOND_ALIVE, SLAB, ROW_LEN, OTHER, STATE];
        d.slabs
            .iter()
            .map(|s| Kernel::bind_lanes(device, &p.bonds, &lanes, &[d, s, l], groups))
            .collect::<Result<_>>()?
    };
    let geometry = [pf::PARAMS, ORIGIN, DISP, pf::TETS, pf::PORE_TET_START, pf::PORE_TETS, pf::VOLUME, pf::CENTRE];
    let conductance = [pf::PARAMS, ORIGIN, DISP, pf::VOLUME, pf::CENTRE, pf::THROATS, pf::CONDUCTANCE, pf::BOND_ALIVE];
    let stable_step = [pf::PARAMS, pf::VOLUME, pf::BOUNDARY, pf::ROW_START, pf::ROW, pf::CONDUCTANCE, COUNTERS];
    let forces = [
        pf::PARAMS,
        ORIGIN,
        DISP,
        pf::TETS,
        pf::TET_PORE,
        pf::TET_SIGN,
        pf::PRESSURE,
        pf::ELEM_START,
        pf::ELEM_CORNERS,
        FORCE,
    ];
    let (pressure, mass) = flow_kernels(device, p, l)?;
    Ok(Kernels {
        bonds,
        geometry: bind(&p.geometry, &geometry, np)?,
        conductance: bind(&p.conductance, &conductance, nt)?,
        stable_step: bind(&p.stable_step, &stable_step, np)?,
        pressure,
        mass,
        forces: bind(&p.forces, &forces, ne)?,
        drift: bind(&p.drift, &[pf::PARAMS, DISP, COUNTERS, pf::PORE_BUILT], ne)?,
    })
}

/// The two kernels of one flow sub-step: pressures from the excess masses, then each pore's
/// excess from its row of throats (with what its updates rounded away carried to the next).
fn flow_kernels(device: &wgpu::Device, p: &Pipelines, l: &Lanes) -> Result<(Kernel, Kernel)> {
    let groups = groups_for(l.uniform.pores as usize);
    Ok((
        Kernel::bind_lanes(device, &p.pressure, &PRESSURE_LANES, &[l], groups)?,
        Kernel::bind_lanes(device, &p.mass, &MASS_LANES, &[l], groups)?,
    ))
}

/// The flow update of one network on the device, on its own: the volumes and conductances
/// stay as uploaded (the flow's parity test, `engine/tests/pore_flow_parity.rs`).
pub struct PoreFlowKernel {
    lanes: Lanes,
    pressure: Kernel,
    mass: Kernel,
}

impl PoreFlowKernel {
    /// Uploads the network and fluid of `f` (its current volumes, conductances, boundary
    /// regions and masses) for sub-steps of length `h` (s).
    pub fn upload(ctx: &GpuContext, f: &PoreFlow, h: f64) -> Result<Self> {
        let p = pipelines(ctx, &[], false);
        let lanes = Lanes::upload(ctx, f, &[], &[], h, ctx.limits.max_storage_buffer_binding_size)?;
        let (pressure, mass) = flow_kernels(&ctx.device, &p, &lanes)?;
        Ok(PoreFlowKernel { lanes, pressure, mass })
    }

    /// Runs `n` sub-steps (each: pressures, then masses) in one submission.
    pub fn substeps(&self, ctx: &GpuContext, n: u32) {
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(Stage::PoreFlow.name()),
                timestamp_writes: None,
            });
            for _ in 0..n {
                self.pressure.dispatch(&mut pass);
                self.mass.dispatch(&mut pass);
            }
        }
        ctx.submit(enc);
    }

    /// Brings the masses back into `f` (the f64 mass at the upload plus the f32 change), the
    /// held pores at their pressure, and the pressures and flows from them.
    pub fn download(&self, ctx: &GpuContext, f: &mut PoreFlow) -> Result<()> {
        self.lanes.download(ctx, f, false)
    }
}
