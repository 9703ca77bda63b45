//! The `pore_flow` stage's flow update on the GPU (shaders/pore_flow.wgsl, f32): the pore
//! network's fluid advanced by explicit sub-steps on the device, each pore gathering its own
//! row of throats (no atomics). The network's geometry (volumes, conductances, rebuilds), the
//! stable step and the pressure forces stay on the host; the GPU backend does not run the
//! coupled stage yet (it refuses a plan with pore flow), so this kernel is driven on its own:
//! upload a [`PoreFlow`], run sub-steps, download the masses. CPU twin: `pores/flow.rs`
//! (`PoreFlow::substep`), run by `backend/cpu/pore_flow.rs`.

use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel};
use crate::error::Result;
use crate::plan::Stage;
use crate::pores::PoreFlow;
use wgpu::util::DeviceExt;

/// The kernel's buffers, one field per binding of shaders/pore_flow.wgsl.
pub struct PoreBuffers {
    /// (K_f, ρ0, h, pores).
    pub fluid: wgpu::Buffer,
    /// Per pore (V, fixed pressure, source, held).
    pub pore: wgpu::Buffer,
    /// Per pore m − ρ0·V.
    pub excess: wgpu::Buffer,
    pub pressure: wgpu::Buffer,
    pub row_start: wgpu::Buffer,
    pub row: wgpu::Buffer,
    /// Per throat (a, b).
    pub ends: wgpu::Buffer,
    pub conductance: wgpu::Buffer,
}

/// The flow update of one network on the device.
pub struct PoreFlowKernel {
    pub buffers: PoreBuffers,
    pressure: Kernel,
    mass: Kernel,
    pores: usize,
}

fn storage<T: bytemuck::Pod>(ctx: &GpuContext, label: &str, data: &[T]) -> wgpu::Buffer {
    // A binding may not be empty: a network without throats gets one zero word.
    let bytes: &[u8] = bytemuck::cast_slice(data);
    let zero = [0u8; 16];
    ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if bytes.is_empty() { &zero } else { bytes },
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    })
}

impl PoreFlowKernel {
    /// Uploads the network and fluid of `f` (its current volumes, conductances, boundary
    /// regions and masses) for sub-steps of length `h` (s).
    pub fn upload(ctx: &GpuContext, f: &PoreFlow, h: f64) -> Self {
        let net = &f.network;
        let np = net.pore_count();
        let (k, rho0) = (f.fluid.bulk_modulus, f.fluid.density);
        let fluid: [u32; 4] = [(k as f32).to_bits(), (rho0 as f32).to_bits(), (h as f32).to_bits(), np as u32];
        let pore: Vec<[f32; 4]> = (0..np)
            .map(|p| {
                let held = f.fixed_pressure(p);
                [
                    net.volume[p] as f32,
                    held.unwrap_or(0.0) as f32,
                    f.source[p] as f32,
                    if held.is_some() { 1.0 } else { 0.0 },
                ]
            })
            .collect();
        let excess: Vec<f32> = (0..np).map(|p| (f.mass[p] - rho0 * net.volume[p]) as f32).collect();
        let ends: Vec<[u32; 2]> = net.throats.iter().map(|t| [t.a, t.b]).collect();
        let g: Vec<f32> = net.conductance.iter().map(|&g| g as f32).collect();
        let buffers = PoreBuffers {
            fluid: ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("pore fluid"),
                contents: bytemuck::cast_slice(&fluid),
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            pore: storage(ctx, "pores", &pore),
            excess: storage(ctx, "pore excess mass", &excess),
            pressure: storage(ctx, "pore pressure", &vec![0f32; np]),
            row_start: storage(ctx, "pore rows", &net.row_start),
            row: storage(ctx, "pore row throats", &net.row),
            ends: storage(ctx, "throat ends", &ends),
            conductance: storage(ctx, "throat conductance", &g),
        };
        let [pp, pm] = pipelines(&ctx.device);
        let b = &buffers;
        let groups = groups_for(np);
        let pressure =
            Kernel::bind_at(&ctx.device, &pp, &[(0, &b.fluid), (1, &b.pore), (2, &b.excess), (3, &b.pressure)], groups);
        let all = [&b.fluid, &b.pore, &b.excess, &b.pressure, &b.row_start, &b.row, &b.ends, &b.conductance];
        let mass = Kernel::bind(&ctx.device, &pm, &all, groups);
        PoreFlowKernel { buffers, pressure, mass, pores: np }
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
                for k in [&self.pressure, &self.mass] {
                    pass.set_pipeline(&k.pipeline);
                    pass.set_bind_group(0, &k.bind_group, &[]);
                    pass.dispatch_workgroups(k.groups.0, k.groups.1, 1);
                }
            }
        }
        ctx.queue.submit([enc.finish()]);
    }

    /// Brings the masses back into `f` (m = ρ0·V + e, in f64), the held pores at their
    /// pressure, and the pressures from them.
    pub fn download(&self, ctx: &GpuContext, f: &mut PoreFlow) -> Result<()> {
        let e: Vec<f32> = super::buffers::read(ctx, &self.buffers.excess, self.pores)?;
        let (k, rho0) = (f.fluid.bulk_modulus, f.fluid.density);
        for p in 0..self.pores {
            let v = f.network.volume[p];
            f.mass[p] = match f.fixed_pressure(p) {
                Some(held) => rho0 * v * (1.0 + held / k),
                None => rho0 * v + f64::from(e[p]),
            };
        }
        f.update_pressure();
        Ok(())
    }
}

/// The two passes of one flow sub-step: pressures from masses, then each pore's mass from its
/// row of throats.
pub fn pipelines(device: &wgpu::Device) -> [wgpu::ComputePipeline; 2] {
    ["pore_pressure", "pore_mass"]
        .map(|e| shaders::pipeline(device, Stage::PoreFlow.name(), shaders::PORE_FLOW, e, &[]))
}
