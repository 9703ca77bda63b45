//! The `periodic` stage on the GPU (shaders/periodic.wgsl): one dispatch a step after the move
//! wraps each element into the cell and counts its crossings per axis; a download shifts each
//! element's displacement origin on the host by its crossings times the spans (the device's
//! positions come back wrapped). The pairs' nearest images are the core kernels' (rows,
//! contact forces, guard, drift: `shaders/periodic_image.wgsl`, behind the PERIODIC override).
//! Built only when the plan has the stage. CPU twin: `effects/periodic/cpu.rs`.

use crate::backend::gpu::bindings::{Holder, Lane};
use crate::backend::gpu::buffers::{read, DeviceLanes};
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::shaders::{self, groups_for, Kernel};
use crate::effects::periodic::Periodic;
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
        source: include_str!("../../../../shaders/periodic.wgsl"),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read(ORIGIN),
            read_write(DISP),
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
    pub bytes: u64,
}

impl Holder for Session {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        (lane == pl::CROSSINGS).then_some(&self.crossings)
    }
}

impl Session {
    pub fn upload(ctx: &GpuContext, constants: &[(&str, f64)], m: &Model, lanes: &DeviceLanes) -> Result<Self> {
        let n = m.len().max(1);
        let crossings = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("periodic crossings"),
            contents: &vec![0u8; 16 * n],
            // COPY_DST: a download clears it on the device.
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        });
        let cell = m.settings.periodic.expect("the plan has the periodic stage");
        let mut s = Session { crossings, kernel: None, n: m.len(), cell, bytes: 16 * n as u64 };
        let pipeline = shaders::pipeline(ctx, Stage::Periodic.name(), &SHADER, "periodic", constants);
        s.kernel = Some(Kernel::bind(&ctx.device, &pipeline, &[lanes, &s], groups_for(m.len()))?);
        Ok(s)
    }

    pub fn kernel(&self) -> Option<&Kernel> {
        self.kernel.as_ref()
    }

    /// Shifts each element's displacement origin by the spans it crossed since the upload (the
    /// counts are not reset: a download is followed by a new upload or by the same session,
    /// whose positions the host then holds wrapped; see the backend's `rewind`).
    pub fn download(&self, ctx: &GpuContext, m: &mut Model) -> Result<()> {
        let k = read::<[i32; 4]>(ctx, &self.crossings, self.n)?;
        let image = self.cell.image();
        let p = &mut m.particles;
        for (i, (o, c)) in p.origin.iter_mut().zip(&k).enumerate() {
            if p.fixed[i] & crate::state::particles::dof::CLUMPED != 0 {
                // A member went where its clump's wrapped centre put it: its origin follows by
                // whole spans, to the image nearest its position (its true displacement since
                // the rows' build is far below half a span).
                let d = p.pos[i] - *o;
                *o += image.len.component_mul(&d.component_mul(&image.inv).map(f64::round));
                continue;
            }
            for a in 0..3 {
                o[a] += f64::from(c[a]) * image.len[a];
            }
        }
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&self.crossings, 0, None);
        ctx.submit(enc);
        Ok(())
    }
}
