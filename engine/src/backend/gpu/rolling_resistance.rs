//! The `rolling_resistance` stage on the GPU (shaders/rolling_resistance.wgsl): the pipeline,
//! with μ_r and η_r as pipeline constants of its own (the model is common.wgsl's
//! `ROLLING_SPRING`), and one kernel per slab of rows bound to the particles' lanes and, for
//! epsd, the slab's rolling springs (uploaded, carried through the device's row builds and
//! downloaded with the pair states: `buffers.rs`, `rows.rs`), and the heat ledger (the torques'
//! work is friction heat). cdt has no lanes. Built only when
//! the plan has the stage. CPU twin: `backend/cpu/rolling_resistance.rs`.

use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::physics::rolling_resistance::RollingResistance;
use crate::plan::Stage;

pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)], r: &RollingResistance) -> Pipeline {
    let mut constants = constants.to_vec();
    constants.push(("ROLLING_MU", r.mu_r));
    constants.push(("ROLLING_DAMPING", r.damping));
    let name = Stage::RollingResistance.name();
    shaders::pipeline(device, name, &shaders::ROLLING_RESISTANCE, name, &constants)
}

pub fn kernels(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Vec<Kernel>> {
    d.slabs.iter().map(|s| Kernel::bind(device, p, &[d, s], groups_for(s.count))).collect()
}
