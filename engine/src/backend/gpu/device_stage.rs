//! An optional stage's work on the device, as one object per upload: its lanes and its kernels
//! bound to them, what a step dispatches, and what a download brings back. The effect's
//! `gpu.rs` builds its [`DeviceStage`] at each upload (its `upload`, an [`Upload`]); the backend
//! lists the uploads once (`DEVICE_STAGES` in `mod.rs`), keeps what they return in
//! [`DeviceStages`] and walks it at each step in the plan's order and at each download, so such
//! a stage names nothing else in the backend: no pipeline field, no lane field, no arm.
//!
//! Two optional stages are still held by name, because the batch loop itself depends on them:
//! the periodic cell (under Lees–Edwards shear its offset is copied into the params before each
//! step, and its slip enters the rows' rebuild rule) and pore flow (its sub-steps and network
//! rebuilds are decided between batches from the counters).

use crate::backend::gpu::buffers::DeviceLanes;
use crate::backend::gpu::device::GpuContext;
use crate::backend::gpu::shaders::Kernel;
use crate::error::Result;
use crate::model::Model;
use crate::plan::{Stage, StepPlan};
use std::any::Any;

/// One upload's work of a stage.
pub trait DeviceStage: Any {
    /// What step `step` (the model's step count when it starts) dispatches, in order; none when
    /// the stage is not due after it (a field stage that runs every few steps).
    fn kernels(&self, step: u64) -> Vec<&Kernel>;
    /// Bytes of the stage's own lanes on the device.
    fn bytes(&self) -> u64;
    /// Brings the stage's state back into the model (after the core's lanes came back).
    /// `stages` are the upload's stages, for one that reads another's lanes.
    fn download(&self, _ctx: &GpuContext, _lanes: &DeviceLanes, _m: &mut Model, _stages: &DeviceStages) -> Result<()> {
        Ok(())
    }
    /// Whether it keeps sums since the upload that a download adds to the model, so that the
    /// session cannot continue after one (it uploads afresh).
    fn keeps_sums(&self) -> bool {
        false
    }
}

/// What an upload gives each stage to build its work from.
pub struct UploadContext<'a> {
    pub ctx: &'a GpuContext,
    /// The plan's pipeline constants: pipelines are compiled once per device and cached by
    /// source and constants, so building them at each upload costs a lookup.
    pub constants: &'a [(&'static str, f64)],
    pub plan: &'a StepPlan,
    /// The core's lanes, which the stage's kernels bind beside its own.
    pub lanes: &'a DeviceLanes,
    /// The largest storage binding, in bytes.
    pub limit: u64,
    /// The stages uploaded before this one (`DEVICE_STAGES`' order), for one that binds another's
    /// lanes.
    pub earlier: &'a DeviceStages,
}

/// Builds a stage's work for one upload; `None` when the plan does not run the stage.
pub type Upload = fn(m: &mut Model, u: &UploadContext) -> Result<Option<Box<dyn DeviceStage>>>;

/// The stages one upload built, in `DEVICE_STAGES`' order.
#[derive(Default)]
pub struct DeviceStages(Vec<(Stage, Box<dyn DeviceStage>)>);

impl DeviceStages {
    pub fn push(&mut self, stage: Stage, work: Box<dyn DeviceStage>) {
        self.0.push((stage, work));
    }

    /// The stage's work, when the upload built it.
    pub fn get(&self, stage: Stage) -> Option<&dyn DeviceStage> {
        self.0.iter().find(|(s, _)| *s == stage).map(|(_, w)| w.as_ref())
    }

    /// The stage's work as its own type (another stage's lanes, bound beside one's own).
    pub fn find<T: DeviceStage>(&self, stage: Stage) -> Option<&T> {
        let any: &dyn Any = self.get(stage)?;
        any.downcast_ref()
    }

    pub fn iter(&self) -> impl Iterator<Item = &(Stage, Box<dyn DeviceStage>)> {
        self.0.iter()
    }

    pub fn bytes(&self) -> u64 {
        self.0.iter().map(|(_, w)| w.bytes()).sum()
    }

    /// Whether any keeps sums since the upload ([`DeviceStage::keeps_sums`]).
    pub fn keep_sums(&self) -> bool {
        self.0.iter().any(|(_, w)| w.keeps_sums())
    }
}
