//! The `rolling_resistance` stage on the GPU (shaders/rolling_resistance.wgsl): the pipeline,
//! with μ_r and η_r as pipeline constants of its own (the model is common.wgsl's
//! `ROLLING_SPRING`), and one kernel per slab of rows bound to the particles' lanes and, for
//! epsd, the slab's rolling springs (uploaded, carried through the device's row builds and
//! downloaded with the pair states: `buffers.rs`, `rows.rs`), and the heat ledger (the torques'
//! work is friction heat). cdt has no lanes. Built only when
//! the plan has the stage. CPU twin: `backend/cpu/rolling_resistance.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, Kernel};
use crate::physics::rolling_resistance::RollingResistance;
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)], r: &RollingResistance) -> wgpu::ComputePipeline {
    let mut constants = constants.to_vec();
    constants.push(("ROLLING_MU", r.mu_r));
    constants.push(("ROLLING_DAMPING", r.damping));
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
            &s.rolling,
            &s.wall_rolling,
            &d.heat,
        ]
    })
}
