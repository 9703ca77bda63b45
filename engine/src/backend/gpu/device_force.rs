//! An optional force stage whose device work is one upload's kernels and nothing more: no state
//! a download brings back, no other stage's lanes (applied loads, the confining pressure,
//! buoyancy). The effect's `gpu.rs` builds its [`DeviceForce`] at each upload (its `upload`, an
//! [`Upload`]); the backend lists them once (`FORCE_STAGES` in `mod.rs`) and dispatches each at
//! its place in the step, so such a stage names nothing else in the backend. The force stages
//! that keep state across a download or per slab (parallel bonds, rolling resistance, pore flow)
//! and the field stages are still held by name.

use crate::backend::gpu::buffers::DeviceLanes;
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::shaders::Kernel;
use crate::error::Result;
use crate::model::Model;
use crate::plan::StepPlan;

/// One upload's work of a force stage.
pub trait DeviceForce {
    /// What one step dispatches, in order.
    fn kernels(&self) -> Vec<&Kernel>;
    /// Bytes of the stage's own lanes on the device.
    fn bytes(&self) -> u64;
}

/// Builds a stage's work for one upload: its pipelines (compiled once per device and cached by
/// source and constants) bound to the upload's lanes (`lanes`, storage bindings of at most
/// `limit` bytes). `None` when the plan does not run the stage.
pub type Upload = fn(
    ctx: &GpuContext,
    constants: &[(&str, f64)],
    m: &Model,
    plan: &StepPlan,
    lanes: &DeviceLanes,
    limit: u64,
) -> Result<Option<Box<dyn DeviceForce>>>;
