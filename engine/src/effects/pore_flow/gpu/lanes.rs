//! The `pore_flow` stage's own buffers on the GPU for one upload (the network's topology,
//! per-pore and per-throat lanes), and the lanes of a flow sub-step's kernels, which the
//! fluid's temperature (`pore_heat.rs`) binds too.

use crate::backend::gpu::bindings::{Holder, Lane};
use crate::backend::gpu::buffers::{read, storage_lane};
use crate::backend::gpu::device::GpuContext;
use crate::effects::pore_flow::gpu::wgsl as pf;
use crate::effects::pore_flow::network::{face_corners, VOLUME_FLOOR};
use crate::effects::pore_flow::PoreFlow;
use crate::error::Result;
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

/// The fluid and the network's sizes (`PoreParams` in pore_flow.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(super) struct PoreParams {
    bulk_modulus: f32,
    density: f32,
    viscosity: f32,
    h: f32,
    pub(super) pores: u32,
    pub(super) throats: u32,
    pub(super) elements: u32,
    pub(super) bond_edges: u32,
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
    pub(super) uniform: PoreParams,
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
    pub(super) fn upload(
        ctx: &GpuContext,
        f: &PoreFlow,
        built: &[[f32; 4]],
        factors: &[f64],
        h: f64,
        limit: u64,
    ) -> Result<Self> {
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
    pub(super) fn set_substep(&mut self, ctx: &GpuContext, h: f64) {
        self.uniform.h = h as f32;
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&self.uniform));
    }

    /// Brings the fluid back into `f`: each pore's mass is its f64 mass at the upload plus the
    /// f32 change, the mass the boundary regions supplied is booked to them, the held pores
    /// are set to their pressure at the host's volume, and the pressures and flows follow.
    pub(super) fn download(&self, ctx: &GpuContext, f: &mut PoreFlow, geometry: bool) -> Result<()> {
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
