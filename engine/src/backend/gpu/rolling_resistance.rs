//! The `rolling_resistance` stage on the GPU (shaders/rolling_resistance.wgsl): the cdt model's
//! pipeline, with μ_r as a pipeline constant of its own, and one kernel per slab of rows bound to
//! the particles' lanes. The stage has no lanes of its own. Built only when the plan has the
//! stage; the epsd model (whose springs would have to be carried through the device's row
//! builds) runs on the CPU backend only, and `GpuBackend::with_plan` refuses it with that
//! advice. CPU twin: `backend/cpu/rolling_resistance.rs`.

use super::buffers::DeviceLanes;
use super::shaders::{self, Kernel};
use crate::physics::rolling_resistance::RollingResistance;
use crate::plan::Stage;

pub fn pipeline(device: &wgpu::Device, constants: &[(&str, f64)], r: &RollingResistance) -> wgpu::ComputePipeline {
    let mut constants = constants.to_vec();
    constants.push(("ROLLING_MU", r.mu_r));
    let name = Stage::RollingResistance.name();
    shaders::pipeline(device, name, shaders::ROLLING_RESISTANCE, name, &constants)
}

pub fn kernels(device: &wgpu::Device, p: &wgpu::ComputePipeline, d: &DeviceLanes) -> Vec<Kernel> {
    d.per_slab(device, p, |s| {
        vec![
            &d.params,
            &d.origin,
            &d.disp,
            &d.body,
            &d.kind,
            &d.row_len,
            &s.other,
            &d.pairs,
            &d.ang_vel,
            &d.torque,
            &s.uniform,
            &d.walls,
            &d.wall_pairs,
        ]
    })
}
