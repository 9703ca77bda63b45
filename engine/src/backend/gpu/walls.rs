//! The `walls` stage on the GPU: the wall loads of the last step are summed and the walls move
//! (prescribed velocity or servo), in one single-workgroup dispatch (shaders/walls.wgsl),
//! so a servo platen runs without a round trip to the host; in scenes of more than 256
//! workgroups (16,384 particles) the partials are first folded 64 at a time by a parallel
//! dispatch. Built only when the scene has walls. CPU twin: [`crate::walls::Wall::advance`].

use super::bindings::{FOLDED, PARAMS, PARTIALS};
use super::buffers::DeviceLanes;
use super::device::GpuContext;
use super::shaders::{self, grid, Kernel, Pipeline};
use crate::error::Result;
use crate::plan::Stage;

/// The walls moved by a step; with `sums`, after the last step's loads are summed (what a
/// servo steers by: a plan without one moves its walls alone).
pub fn pipeline(device: &GpuContext, constants: &[(&str, f64)], sums: bool) -> Pipeline {
    let mut constants = constants.to_vec();
    if !sums {
        constants.push(("SUM_LOADS", 0.0));
    }
    shaders::pipeline(device, Stage::Walls.name(), &shaders::WALLS, "advance_walls", &constants)
}

/// The loads alone (no move), so the host reads the loads of the run's last step.
pub fn sum_pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, "sum_wall_loads", &shaders::WALLS, "sum_wall_loads", constants)
}

pub fn kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes) -> Result<Kernel> {
    Kernel::bind(device, p, &[d], (1, 1))
}

/// Folds the wall pass's partials 64 workgroups at a time, before a load sum.
pub fn fold_pipeline(device: &GpuContext, constants: &[(&str, f64)]) -> Pipeline {
    shaders::pipeline(device, "fold_wall_partials", &shaders::WALLS, "fold_partials", constants)
}

/// The fold's kernel, when the scene has more than [`FOLD_PAST`] partials per wall (`None`
/// otherwise: the load sum reads the partials themselves).
pub fn fold_kernel(device: &wgpu::Device, p: &Pipeline, d: &DeviceLanes, blocks: usize) -> Result<Option<Kernel>> {
    if blocks == 0 {
        return Ok(None);
    }
    Kernel::bind_lanes(device, p, &[PARAMS, PARTIALS, FOLDED], &[d], grid(blocks)).map(Some)
}

/// Wall-pass workgroups past which their partials are folded before the sum. Below it the
/// sum's invocations read at most 4 partials a wall one after another, which costs a hardware
/// GPU about what one more dispatch does (a few µs); above it the chain grows with the scene.
const FOLD_PAST: usize = 256;

/// Blocks of 64 that the `groups` partials per wall are folded into before they are summed;
/// 0 when there are at most [`FOLD_PAST`] (the load sum reads them itself).
pub fn blocks(groups: usize) -> usize {
    if groups > FOLD_PAST {
        groups.div_ceil(64)
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::blocks;

    #[test]
    fn partials_are_folded_only_past_four_per_invocation() {
        assert_eq!(blocks(1), 0);
        assert_eq!(blocks(256), 0);
        assert_eq!(blocks(257), 5);
        assert_eq!(blocks(4096), 64);
        // 10 M particles: 156,250 workgroups, each invocation of the sum then reads 39 values.
        assert_eq!(blocks(156_250), 2442);
    }
}
