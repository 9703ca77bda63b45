//! The `pore_flow` stage's flow update on the GPU (shaders/pore_flow.wgsl). CPU twin:
//! `pores/flow.rs` (`PoreFlow::substep`), run by `backend/cpu/pore_flow.rs`.

use super::shaders;
use crate::plan::Stage;

/// The two passes of one flow sub-step: pressures from masses, then each pore's mass from its
/// row of throats.
pub fn pipelines(device: &wgpu::Device) -> [wgpu::ComputePipeline; 2] {
    ["pore_pressure", "pore_mass"]
        .map(|e| shaders::pipeline(device, Stage::PoreFlow.name(), shaders::PORE_FLOW, e, &[]))
}
