//! The `rolling_resistance` stage on the GPU (shaders/rolling_resistance.wgsl): the pipeline,
//! with μ_r and η_r as pipeline constants of its own (the model is common.wgsl's
//! `ROLLING_SPRING`), and one kernel per slab of rows bound to the particles' lanes and, for
//! epsd, the slab's rolling springs (uploaded, carried through the device's row builds and
//! downloaded with the pair states: `buffers.rs`, `rows.rs`), and the heat ledger (the torques'
//! work is friction heat). cdt has no lanes. Built only when
//! the plan has the stage. CPU twin: `effects/rolling_resistance/cpu.rs`.

use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::device_stage::{DeviceStage, UploadContext};
use crate::backend::gpu::shaders::{self, groups_for, Kernel, Pipeline};
use crate::effects::rolling_resistance::physics::RollingResistance;
use crate::error::Result;
use crate::model::Model;
use crate::plan::Stage;

/// The stage's WGSL and its bindings in order, from which its `@binding` lines are generated.
pub use shader::SHADER;

mod shader {
    use crate::backend::gpu::bindings::{self as b, *};
    use crate::backend::gpu::shaders::Shader;

    pub const SHADER: Shader = Shader {
        name: "rolling_resistance",
        source: concat!(
            include_str!("../../../../shaders/periodic_image.wgsl"),
            "\n",
            include_str!("../../../../shaders/rolling_resistance.wgsl")
        ),
        bindings: Bindings(&[&[
            uniform(PARAMS),
            read(ORIGIN),
            read(DISP),
            read(BODY),
            read(KIND),
            read(ROW_LEN),
            read(OTHER),
            read(PAIRS),
            read(ANG_VEL),
            read_write(TORQUE),
            uniform(SLAB),
            read(b::WALLS),
            read(WALL_PAIRS),
            read_write(ROLLING),
            read_write(WALL_ROLLING),
            read_write(HEAT),
        ]]),
    };
}

fn pipeline(device: &GpuContext, constants: &[(&str, f64)], r: &RollingResistance) -> Pipeline {
    let mut constants = constants.to_vec();
    constants.push(("ROLLING_MU", r.mu_r));
    constants.push(("ROLLING_DAMPING", r.damping));
    let name = Stage::RollingResistance.name();
    shaders::pipeline(device, name, &SHADER, name, &constants)
}

/// The stage for one upload, when the plan has it (`device_stage::Upload`): one kernel per slab
/// of rows; its springs are the core's lanes (nothing of its own to download).
pub fn upload(_: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>> {
    let Some(r) = &u.plan.rolling else { return Ok(None) };
    let (device, d) = (&u.ctx.device, u.lanes);
    let p = pipeline(u.ctx, u.constants, r);
    let slabs =
        d.slabs.iter().map(|s| Kernel::bind(device, &p, &[d, s], groups_for(s.count))).collect::<Result<_>>()?;
    Ok(Some(Box::new(Slabs(slabs))))
}

struct Slabs(Vec<Kernel>);

impl DeviceStage for Slabs {
    fn kernels(&self, _: u64) -> Vec<&Kernel> {
        self.0.iter().collect()
    }

    fn bytes(&self) -> u64 {
        0
    }
}
