//! The `periodic` stage on the GPU (shaders/periodic.wgsl): one dispatch a step after the move
//! wraps each element into the cell and counts its crossings per axis; a download shifts each
//! element's displacement origin on the host by its crossings times the spans (the device's
//! positions come back wrapped). The pairs' nearest images are the core kernels' (rows,
//! contact forces, guard, drift: `shaders/periodic_image.wgsl`, behind the PERIODIC override).
//!
//! Under Lees–Edwards shear (the SHEAR override) the images' offset changes every step: the
//! host works out each step's offsets in f64 as the CPU advances them, writes a batch's
//! schedule, and the batch copies each step's entry into the params before that step's
//! dispatches ([`Shear`]). Built only when the plan has the stage. CPU twin:
//! `effects/periodic/cpu.rs`.

use crate::backend::gpu::bindings::{Holder, Lane};
use crate::backend::gpu::buffers::{read, DeviceLanes};
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::shaders::{self, groups_for, Kernel};
use crate::effects::periodic::{setting, Periodic};
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;
use wgpu::util::DeviceExt;

use wgsl as pl;

/// The stage's own lanes, as its WGSL names them.
pub mod wgsl {
    use crate::backend::gpu::bindings::{lane, Home, Lane};

    /// Per element, its crossings of each periodic axis since the upload (+1: in through the
    /// lower face, having left through the upper).
    pub const CROSSINGS: Lane = lane(Home::Effect("periodic"), "crossings", "array<vec4<i32>>");
}

pub use shader::SHADER;

mod shader {
    use super::pl;
    use crate::backend::gpu::bindings::*;
    use crate::backend::gpu::shaders::Shader;

    pub const SHADER: Shader = Shader {
        name: "periodic",
        source: concat!(
            include_str!("../../../../shaders/periodic_image.wgsl"),
            "\n",
            include_str!("../../../../shaders/periodic.wgsl")
        ),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read(ORIGIN),
            read_write(DISP),
            read_write(VEL),
            read(KIND),
            read_write(pl::CROSSINGS),
        ]]),
    };
}

/// The crossings and the kernel for one upload.
pub struct Session {
    crossings: wgpu::Buffer,
    kernel: Option<Kernel>,
    n: usize,
    cell: Periodic,
    shear: Option<Shear>,
    pub bytes: u64,
}

impl Holder for Session {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        (lane == pl::CROSSINGS).then_some(&self.crossings)
    }
}

/// Lees–Edwards shear on the device: the offset as the host advances it, step by step in f64
/// as the CPU does, and the schedule a batch copies into the params, one entry a step
/// (`Params::shear`: this step's offset, the next step's, the slide γ̇·L_z).
struct Shear {
    schedule: wgpu::Buffer,
    /// Entries the schedule holds: a batch's steps and one for what ends it.
    room: u64,
    rate: f64,
    dt: f64,
    /// The spans along x and z (m).
    lx: f64,
    lz: f64,
    /// The offset after the steps run so far, and when the device's rows were last built.
    offset: f64,
    offset_at_build: f64,
}

/// Bytes of one schedule entry (a vec4<f32>).
const ENTRY: u64 = 16;

impl Shear {
    fn next(&self, offset: f64) -> f64 {
        (offset + self.rate * self.lz * self.dt).rem_euclid(self.lx)
    }

    /// The entry of the params for the step whose stages see `offset`.
    fn entry(&self, offset: f64) -> [f32; 4] {
        [offset as f32, self.next(offset) as f32, (self.rate * self.lz) as f32, 0.0]
    }
}

impl Session {
    /// The stage's lanes and kernel; under Lees–Edwards shear a schedule of `batch` + 1
    /// entries, and the params' first entry written.
    pub fn upload(
        ctx: &GpuContext,
        constants: &[(&str, f64)],
        m: &Model,
        lanes: &DeviceLanes,
        batch: u64,
    ) -> Result<Self> {
        let n = m.len().max(1);
        let crossings = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("periodic crossings"),
            contents: &vec![0u8; 16 * n],
            // COPY_DST: a download clears it on the device.
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        });
        let cell = m.effects.periodic.cell.expect("the plan has the periodic stage");
        let span = |k: usize| cell.axes[k].map_or(0.0, |[lo, hi]| hi - lo);
        let shear = cell.shear.map(|s| {
            let room = batch + 1;
            let schedule = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Lees–Edwards schedule"),
                size: room * ENTRY,
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let (lx, lz) = (span(0), span(2));
            Shear {
                schedule,
                room,
                rate: s.rate,
                dt: m.clock.dt,
                lx,
                lz,
                offset: s.offset,
                offset_at_build: s.offset_at_build,
            }
        });
        if let Some(sh) = &shear {
            ctx.queue.write_buffer(&lanes.params, SHEAR_AT, bytemuck::cast_slice(&sh.entry(sh.offset)));
        }
        let bytes = 16 * n as u64 + shear.as_ref().map_or(0, |s| s.room * ENTRY);
        let mut s = Session { crossings, kernel: None, n: m.len(), cell, shear, bytes };
        let pipeline = shaders::pipeline(ctx, Stage::Periodic.name(), &SHADER, "periodic", constants);
        s.kernel = Some(Kernel::bind(&ctx.device, &pipeline, &[lanes, &s], groups_for(m.len()))?);
        Ok(s)
    }

    pub fn kernel(&self) -> Option<&Kernel> {
        self.kernel.as_ref()
    }

    /// Under Lees–Edwards shear, writes the schedule of the next `k` steps (and the entry for
    /// what follows them) and says so: the batch then copies entry `t` into the params before
    /// step `t` ([`copy_entry`](Self::copy_entry)). `false` without shear.
    pub fn schedule(&self, ctx: &GpuContext, k: u64) -> Result<bool> {
        let Some(sh) = &self.shear else { return Ok(false) };
        if k + 1 > sh.room {
            return Err(crate::error::GpuError::Device(format!(
                "a batch of {k} steps is longer than the Lees–Edwards schedule's {} entries",
                sh.room
            ))
            .into());
        }
        let mut offset = sh.offset;
        let mut entries = Vec::with_capacity(k as usize + 1);
        for _ in 0..=k {
            entries.push(sh.entry(offset));
            offset = sh.next(offset);
        }
        ctx.queue.write_buffer(&sh.schedule, 0, bytemuck::cast_slice(&entries));
        Ok(true)
    }

    /// Copies the schedule's entry `t` into the params (between compute passes).
    pub fn copy_entry(&self, enc: &mut wgpu::CommandEncoder, params: &wgpu::Buffer, t: u64) {
        if let Some(sh) = &self.shear {
            enc.copy_buffer_to_buffer(&sh.schedule, t * ENTRY, params, SHEAR_AT, ENTRY);
        }
    }

    /// Counts `k` steps run: the offset advances as the CPU advances it.
    pub fn stepped(&mut self, k: u64) {
        if let Some(sh) = self.shear.as_mut() {
            for _ in 0..k {
                sh.offset = sh.next(sh.offset);
            }
        }
    }

    /// The device rebuilt the rows: the slide since their build starts again.
    pub fn rows_built(&mut self) {
        if let Some(sh) = self.shear.as_mut() {
            sh.offset_at_build = sh.offset;
        }
    }

    /// Under Lees–Edwards shear, how far the images have slid since the rows were built and
    /// their slide γ̇·L_z (m, m/s), for the batch rule; `None` without shear.
    pub fn sliding(&self) -> Option<(f64, f64)> {
        let sh = self.shear.as_ref()?;
        let cell = Periodic {
            shear: Some(setting::Shear { rate: sh.rate, offset: sh.offset, offset_at_build: sh.offset_at_build }),
            ..self.cell
        };
        Some((cell.slip_since_build(), sh.rate * sh.lz))
    }

    /// Shifts each element's displacement origin by the spans it crossed since the upload (and,
    /// under Lees–Edwards shear, by the x shifts its z crossings took), and gives the model the
    /// shear's offset (the counts are not reset: a download is followed by a new upload or by
    /// the same session, whose positions the host then holds wrapped; see the backend's
    /// `rewind`).
    pub fn download(&self, ctx: &GpuContext, m: &mut Model) -> Result<()> {
        let k = read::<[i32; 4]>(ctx, &self.crossings, self.n)?;
        let image = match (&self.shear, m.effects.periodic.cell.as_mut().and_then(|c| c.shear.as_mut())) {
            (Some(sh), Some(s)) => {
                (s.offset, s.offset_at_build) = (sh.offset, sh.offset_at_build);
                m.effects.periodic.cell.map(|c| c.image()).unwrap_or_default()
            }
            _ => self.cell.image(),
        };
        let p = &mut m.particles;
        for (i, (o, c)) in p.origin.iter_mut().zip(&k).enumerate() {
            if p.fixed[i] & crate::state::particles::dof::CLUMPED != 0 {
                // A member went where its clump's wrapped centre put it: its origin follows by
                // the image shift to its position (its true displacement since the rows' build
                // is far below half a span; under shear the offset has moved by at most the
                // slide since then).
                let d = p.pos[i] - *o;
                *o += image.shift_of(d);
                continue;
            }
            for a in 0..3 {
                o[a] += f64::from(c[a]) * image.len[a];
            }
            if self.shear.is_some() {
                o.x += f64::from(f32::from_bits(c[3] as u32));
            }
        }
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.crossings, 0, None);
        ctx.submit(enc);
        Ok(())
    }
}

/// Where `Params::shear` lies in the params (bytes).
const SHEAR_AT: u64 = std::mem::offset_of!(crate::backend::gpu::buffers::Params, shear) as u64;
