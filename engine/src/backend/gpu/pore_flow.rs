//! The `pore_flow` stage on the GPU (shaders/pore_flow.wgsl, f32), a force stage between
//! `rolling_resistance` (or `wall_forces`) and `integrate`: the pipelines, the stage's own
//! buffers (the network's topology, per-pore and per-throat lanes) and the kernels bound to
//! them and to the particles' lanes. Built only when the plan has the stage. CPU twin:
//! `backend/cpu/pore_flow.rs`.
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
//! the same step ([`super::pore_heat`], shaders/pore_heat.wgsl): its pressure and mass kernels
//! take the place of `pore_pressure` and `pore_mass`, and the exchange with the grains runs
//! after the flow, before the pressure forces.
//!
//! The flow update alone is also driven by [`PoreFlowKernel`] (upload a network, run sub-steps,
//! download the masses), for the flow's own parity test.

use super::bindings::{pore_flow as pf, Holder, Lane, COUNTERS, DISP, FORCE, ORIGIN, OTHER, ROW_LEN, SLAB, STATE};
use super::buffers::{read, storage_lane, DeviceLanes, HostLanes};
use super::conduction;
use super::device::GpuContext;
use super::pore_heat::{self, PoreHeatSession};
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use crate::pores::network::{face_corners, VOLUME_FLOOR};
use crate::pores::PoreFlow;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

/// The fluid and the network's sizes (`PoreParams` in pore_flow.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PoreParams {
    bulk_modulus: f32,
    density: f32,
    viscosity: f32,
    h: f32,
    pores: u32,
    throats: u32,
    elements: u32,
    bond_edges: u32,
    cement_factor: f32,
    crack_aperture: f32,
    volume_floor: f32,
    one: f32,
}

/// A throat (`Throat` in pore_flow.wgsl), 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ThroatLane {
    a: u32,
    b: u32,
    corners: [u32; 3],
    bits: u32,
    first_edge: u32,
    factor: f32,
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
    shaders::pipeline(device, Stage::PoreFlow.name(), &shaders::PORE_FLOW, entry, constants)
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

/// The stage's buffers for one upload, one field per binding of pore_flow.wgsl (the particles'
/// lanes are the core's).
pub struct Lanes {
    pub(super) params: wgpu::Buffer,
    pub(super) tets: wgpu::Buffer,
    pub(super) tet_pore: wgpu::Buffer,
    pub(super) tet_sign: wgpu::Buffer,
    pub(super) pore_tet_start: wgpu::Buffer,
    pub(super) pore_tets: wgpu::Buffer,
    pub(super) volume: wgpu::Buffer,
    pub(super) volume0: wgpu::Buffer,
    /// The host's volume at the upload (f32 of the f64): the equation of state's volume is it
    /// plus the device's change since, not the device's own (~1e-5 off).
    pub(super) volume_host: wgpu::Buffer,
    pub(super) centre: wgpu::Buffer,
    /// Per pore: the excess mass at the upload (m − ρ0·V) plus the mass gained since.
    pub(super) excess: wgpu::Buffer,
    pub(super) pressure: wgpu::Buffer,
    pub(super) boundary: wgpu::Buffer,
    /// Per pore: the mass its boundary region supplied since the upload (compensated f32 sum).
    pub(super) supplied: wgpu::Buffer,
    /// Per pore: what its excess mass updates rounded away (kg), added back on download.
    pub(super) excess_carry: wgpu::Buffer,
    pub(super) row_start: wgpu::Buffer,
    pub(super) row: wgpu::Buffer,
    pub(super) throats: wgpu::Buffer,
    pub(super) conductance: wgpu::Buffer,
    pub(super) bond_edges: wgpu::Buffer,
    pub(super) bond_alive: wgpu::Buffer,
    pub(super) elem_start: wgpu::Buffer,
    pub(super) elem_corners: wgpu::Buffer,
    pub(super) pore_built: wgpu::Buffer,
    uniform: PoreParams,
    /// The f64 masses and volumes at the upload and the f32 excesses the device started from.
    pub(super) mass0: Vec<f64>,
    pub(super) volume_up: Vec<f64>,
    pub(super) excess0: Vec<f32>,
    /// Bytes of the stage's buffers.
    pub bytes: u64,
}

impl Holder for Lanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        Some(match lane {
            pf::PARAMS => &self.params,
            pf::TETS => &self.tets,
            pf::TET_PORE => &self.tet_pore,
            pf::TET_SIGN => &self.tet_sign,
            pf::PORE_TET_START => &self.pore_tet_start,
            pf::PORE_TETS => &self.pore_tets,
            pf::VOLUME => &self.volume,
            pf::VOLUME0 => &self.volume0,
            pf::VOLUME_HOST => &self.volume_host,
            pf::CENTRE => &self.centre,
            pf::EXCESS => &self.excess,
            pf::PRESSURE => &self.pressure,
            pf::BOUNDARY => &self.boundary,
            pf::SUPPLIED => &self.supplied,
            pf::EXCESS_CARRY => &self.excess_carry,
            pf::ROW_START => &self.row_start,
            pf::ROW => &self.row,
            pf::THROATS => &self.throats,
            pf::CONDUCTANCE => &self.conductance,
            pf::BOND_EDGES => &self.bond_edges,
            pf::BOND_ALIVE => &self.bond_alive,
            pf::ELEM_START => &self.elem_start,
            pf::ELEM_CORNERS => &self.elem_corners,
            pf::PORE_BUILT => &self.pore_built,
            _ => return None,
        })
    }
}

impl Lanes {
    /// Uploads the network and fluid of `f` for sub-steps of `h` (s); `built` is each
    /// element's position at the network's build less its origin on the device (empty for the
    /// flow alone). Refuses a lane larger than `limit` bytes.
    /// `factors` is each throat's permeability factor (empty: 1).
    fn upload(ctx: &GpuContext, f: &PoreFlow, built: &[[f32; 4]], factors: &[f64], h: f64, limit: u64) -> Result<Self> {
        let net = &f.network;
        let np = net.pore_count();
        let fl = &f.fluid;
        let (k, rho0) = (fl.bulk_modulus, fl.density);
        let mut bytes = 0u64;
        let mut make = |lane: &'static str, data: &[u8]| storage_lane(ctx, lane, data, 32, limit, &mut bytes);
        let tets: Vec<[u32; 4]> = net.tri.tets.iter().map(|t| t.v).collect();
        let sign: Vec<f32> = net.orient.iter().map(|&o| o as f32).collect();
        let volume: Vec<f32> = net.volume.iter().map(|&v| v as f32).collect();
        let excess0: Vec<f32> = (0..np).map(|p| (f.mass[p] - rho0 * net.volume[p]) as f32).collect();
        let boundary: Vec<[f32; 4]> = (0..np)
            .map(|p| {
                let held = f.fixed_pressure(p);
                [held.unwrap_or(0.0) as f32, f.source[p] as f32, if held.is_some() { 1.0 } else { 0.0 }, 0.0]
            })
            .collect();
        let mut bond_edges: Vec<[u32; 2]> = Vec::new();
        let throats: Vec<ThroatLane> = net
            .throats
            .iter()
            .zip(&net.bonded_at_build)
            .enumerate()
            .map(|(t, (th, &bits))| {
                let factor = factors.get(t).copied().unwrap_or(1.0);
                let c = face_corners(net.tri.tets[th.tet as usize].v, th.face as usize);
                let first_edge = bond_edges.len() as u32;
                for e in 0..3 {
                    if bits & (1 << e) != 0 {
                        bond_edges.push([c[(e + 1) % 3], c[(e + 2) % 3]]);
                    }
                }
                ThroatLane { a: th.a, b: th.b, corners: c, bits: u32::from(bits), first_edge, factor: factor as f32 }
            })
            .collect();
        let conductance: Vec<f32> = net.conductance.iter().map(|&g| g as f32).collect();
        let uniform = PoreParams {
            bulk_modulus: k as f32,
            density: rho0 as f32,
            viscosity: fl.viscosity as f32,
            h: h as f32,
            pores: np as u32,
            throats: throats.len() as u32,
            elements: built.len() as u32,
            bond_edges: bond_edges.len() as u32,
            cement_factor: fl.cement_factor as f32,
            crack_aperture: fl.crack_aperture as f32,
            volume_floor: VOLUME_FLOOR as f32,
            one: 1.0,
        };
        let lanes = Lanes {
            params: ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("pore parameters"),
                contents: bytemuck::bytes_of(&uniform),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            }),
            tets: make("pore tetrahedra", bytemuck::cast_slice(&tets))?,
            tet_pore: make("pore of each tetrahedron", bytemuck::cast_slice(&net.tet_pore))?,
            tet_sign: make("tetrahedron orientation", bytemuck::cast_slice(&sign))?,
            pore_tet_start: make("pore tetrahedra rows", bytemuck::cast_slice(&net.pore_tet_start))?,
            pore_tets: make("pore tetrahedra ids", bytemuck::cast_slice(&net.pore_tets))?,
            volume: make("pore volume", bytemuck::cast_slice(&volume))?,
            volume0: make("pore volume at upload", bytemuck::cast_slice(&volume))?,
            volume_host: make("pore volume at upload (host)", bytemuck::cast_slice(&volume))?,
            centre: make("pore centre", bytemuck::cast_slice(&vec![[0f32; 4]; np]))?,
            excess: make("pore excess mass", bytemuck::cast_slice(&excess0))?,
            pressure: make("pore pressure", bytemuck::cast_slice(&vec![0f32; np]))?,
            boundary: make("pore boundary", bytemuck::cast_slice(&boundary))?,
            supplied: make("pore supplied mass", bytemuck::cast_slice(&vec![[0f32; 2]; np]))?,
            excess_carry: make("pore excess mass carry", bytemuck::cast_slice(&vec![0f32; np]))?,
            row_start: make("pore rows", bytemuck::cast_slice(&net.row_start))?,
            row: make("pore row throats", bytemuck::cast_slice(&net.row))?,
            throats: make("throats", bytemuck::cast_slice(&throats))?,
            conductance: make("throat conductance", bytemuck::cast_slice(&conductance))?,
            bond_edges: make("throat bonds", bytemuck::cast_slice(&bond_edges))?,
            bond_alive: make("throat bonds holding", bytemuck::cast_slice(&vec![1u32; bond_edges.len()]))?,
            elem_start: make("element corner rows", bytemuck::cast_slice(&net.elem_start))?,
            elem_corners: make("element corners", bytemuck::cast_slice(&net.elem_corners))?,
            pore_built: make("element position at the network's build", bytemuck::cast_slice(built))?,
            uniform,
            mass0: f.mass.clone(),
            volume_up: net.volume.clone(),
            excess0,
            bytes: 0,
        };
        Ok(Lanes { bytes: bytes + std::mem::size_of::<PoreParams>() as u64, ..lanes })
    }

    /// Sets the sub-step length for the following dispatches.
    fn set_substep(&mut self, ctx: &GpuContext, h: f64) {
        self.uniform.h = h as f32;
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&self.uniform));
    }

    /// Brings the fluid back into `f`: each pore's mass is its f64 mass at the upload plus the
    /// f32 change, the mass the boundary regions supplied is booked to them, the held pores
    /// are set to their pressure at the host's volume, and the pressures and flows follow.
    fn download(&self, ctx: &GpuContext, f: &mut PoreFlow, geometry: bool) -> Result<()> {
        let np = self.mass0.len();
        if geometry {
            // The geometry of the last step's stage (before that step's integration), as the
            // CPU's network holds it after a step.
            let net = &mut f.network;
            // Each volume is the f64 volume at the upload plus the change the device measured
            // (its f32 volumes are off by ~1e-5 of themselves, the change is not).
            let v: Vec<f32> = read(ctx, &self.volume, np)?;
            let v0: Vec<f32> = read(ctx, &self.volume0, np)?;
            let c: Vec<[f32; 4]> = read(ctx, &self.centre, np)?;
            let g: Vec<f32> = read(ctx, &self.conductance, net.throats.len())?;
            for p in 0..np {
                net.volume[p] = self.volume_up[p] + (f64::from(v[p]) - f64::from(v0[p]));
                net.centre[p] = crate::physics::Vec3::new(f64::from(c[p][0]), f64::from(c[p][1]), f64::from(c[p][2]));
            }
            for (t, g) in g.iter().enumerate() {
                net.conductance[t] = f64::from(*g);
            }
        }
        let e: Vec<f32> = read(ctx, &self.excess, np)?;
        let s: Vec<[f32; 2]> = read(ctx, &self.supplied, np)?;
        let carry: Vec<f32> = read(ctx, &self.excess_carry, np)?;
        for p in 0..np {
            let rest = f64::from(carry[p]);
            f.mass[p] = self.mass0[p] + (f64::from(e[p]) - f64::from(self.excess0[p])) + rest;
            let dm = f64::from(s[p][0]) + f64::from(s[p][1]);
            if dm != 0.0 {
                f.boundary_mass += dm;
                if let Some(m) = f.region_mass.get_mut(f.region[p] as usize) {
                    *m += dm;
                }
            }
        }
        // A zero-length sub-step: held pores at their pressure (booked), pressures, flows.
        f.substep(0.0);
        Ok(())
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

/// The lanes of a flow sub-step's two kernels (the fluid's temperature adds its own to them).
pub(super) const PRESSURE_LANES: [Lane; 9] = [
    pf::PARAMS,
    pf::VOLUME,
    pf::VOLUME0,
    pf::EXCESS,
    pf::PRESSURE,
    pf::BOUNDARY,
    pf::SUPPLIED,
    pf::EXCESS_CARRY,
    pf::VOLUME_HOST,
];
pub(super) const MASS_LANES: [Lane; 10] = [
    pf::PARAMS,
    pf::EXCESS,
    pf::PRESSURE,
    pf::BOUNDARY,
    pf::SUPPLIED,
    pf::ROW_START,
    pf::ROW,
    pf::THROATS,
    pf::CONDUCTANCE,
    pf::EXCESS_CARRY,
];

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
