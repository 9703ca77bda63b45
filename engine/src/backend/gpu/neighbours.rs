//! Stage 2 on the GPU: the drift measure that decides when neighbour rows are rebuilt
//! (shaders/neighbours.wgsl). The rows themselves are built on the device ([`super::rows`]).

use super::buffers::DeviceLanes;
use super::shaders::{self, groups_for, Kernel};

pub fn pipeline(device: &wgpu::Device, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
    shaders::pipeline(device, "neighbours", shaders::NEIGHBOURS, "measure_drift", constants)
}

pub fn kernel(device: &wgpu::Device, p: &wgpu::ComputePipeline, d: &DeviceLanes) -> Kernel {
    Kernel::bind(device, p, &[&d.params, &d.disp, &d.built, &d.vel, &d.counters], groups_for(d.n))
}

/// Steps the host may run before it must measure the drift again, or `None` when the rows
/// must be rebuilt now. `drift` is the largest move since the build and `speed` the largest
/// speed: the next steps may move a particle by speed·dt each, counted twice for safety
/// against acceleration.
pub fn steps_until_rebuild(drift: f64, speed: f64, skin: f64, dt: f64, most: u64) -> Option<u64> {
    let margin = 0.5 * skin - drift;
    let per_step = 2.0 * speed * dt;
    // NaN (a diverged state) must rebuild too, hence no `margin <= per_step`.
    if margin.partial_cmp(&per_step) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    if per_step == 0.0 {
        return Some(most);
    }
    Some(((margin / per_step) as u64).clamp(1, most))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_rebuilt_before_a_particle_can_drift_half_a_skin() {
        // 0.4 of 1 mm skin: 0.2 mm margin; at 1 m/s and dt 1 µs, 2 µm per step counted.
        assert_eq!(steps_until_rebuild(0.0, 1.0, 0.4e-3, 1e-6, 1000), Some(100));
        assert_eq!(steps_until_rebuild(0.0, 1.0, 0.4e-3, 1e-6, 64), Some(64));
        assert_eq!(steps_until_rebuild(0.199e-3, 1.0, 0.4e-3, 1e-6, 64), None);
        assert_eq!(steps_until_rebuild(0.0, 0.0, 0.4e-3, 1e-6, 64), Some(64));
        assert_eq!(steps_until_rebuild(f64::NAN, 0.0, 0.4e-3, 1e-6, 64), None);
    }
}
