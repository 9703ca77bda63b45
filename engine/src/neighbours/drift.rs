//! The drift rule: rows (and wall masks) hold until something has moved half the skin since
//! they were built; the GPU backend also asks how many steps it may run before it must look.

use crate::effects::periodic::Periodic;
use crate::physics::Vec3;
use crate::state::contacts::Contacts;
use crate::walls::{Wall, WallShape};
use rayon::prelude::*;

/// Whether some particle moved more than half the skin since the rows were built.
pub fn is_stale(c: &Contacts, pos: &[Vec3], cell: Option<&Periodic>) -> bool {
    if c.stale || c.built_at.len() != pos.len() || !c.has_pair_ids() {
        return true;
    }
    let limit = 0.25 * c.skin * c.skin;
    match cell {
        // In a periodic cell an element that crossed a face has moved by its drift, not the span;
        // under Lees–Edwards shear the images across the z faces have slid too, so each element
        // may drift only half of what the slide left of the skin.
        Some(cell) => {
            let slack = c.skin - cell.slip_since_build();
            if slack <= 0.0 {
                return true;
            }
            let (image, limit) = (cell.image(), 0.25 * slack * slack);
            drifted(pos, &c.built_at, |a, b| image.nearest(a - b).norm_squared() > limit)
        }
        None => drifted(pos, &c.built_at, |a, b| (a - b).norm_squared() > limit),
    }
}

/// Whether any element has `moved` from where the rows were built.
#[inline(always)]
fn drifted(pos: &[Vec3], built: &[Vec3], moved: impl Fn(&Vec3, &Vec3) -> bool + Sync) -> bool {
    // Small models: waking the thread pool every step costs more than the check.
    if pos.len() < 16_384 {
        return pos.iter().zip(built).any(|(a, b)| moved(a, b));
    }
    pos.par_iter().zip(built.par_iter()).with_min_len(4096).any(|(a, b)| moved(a, b))
}

/// Whether the wall mask no longer covers the walls: one was added, removed, reshaped, or
/// has moved more than half the skin since the mask was built.
pub fn walls_stale(c: &Contacts, walls: &[Wall], particles: usize) -> bool {
    if c.wall_near.len() != particles || c.walls_at_build.len() != walls.len() {
        return true;
    }
    let limit = 0.5 * c.skin;
    walls.iter().zip(&c.walls_at_build).any(|(w, old)| {
        let moved = match (&w.shape, old) {
            (WallShape::Plane { point, normal }, WallShape::Plane { point: p0, normal: n0 }) if normal == n0 => {
                (point - p0).norm()
            }
            (WallShape::Cylinder { center, radius }, WallShape::Cylinder { center: c0, radius: r0 }) => {
                (center - c0).xy().norm() + (radius - r0).abs()
            }
            (
                WallShape::Cone { apex, axis, half_angle, radius, rod_length },
                WallShape::Cone { apex: a0, axis: x0, half_angle: h0, radius: r0, rod_length: l0 },
            ) if (axis, half_angle, radius, rod_length) == (x0, h0, r0, l0) => (apex - a0).norm(),
            (
                WallShape::Strip { point, normal, axis, lo, hi },
                WallShape::Strip { point: p0, normal: n0, axis: x0, lo: l0, hi: h0 },
            ) if (normal, axis, lo, hi) == (n0, x0, l0, h0) => (point - p0).norm(),
            _ => f64::INFINITY,
        };
        // A NaN move (a wall sent to infinity) counts as stale too.
        moved.is_nan() || moved > limit
    })
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

/// [`steps_until_rebuild`] in a periodic cell sheared by Lees–Edwards images: the images
/// across the z faces have slid `slip` since the build, which brought their pairs that much
/// closer (the skin left is the rest, as in [`is_stale`]), and slide `slide`·dt a step more,
/// half of which the margin (half the skin left) pays.
pub fn steps_until_rebuild_sheared(
    drift: f64,
    speed: f64,
    skin: f64,
    dt: f64,
    most: u64,
    slip: f64,
    slide: f64,
) -> Option<u64> {
    steps_until_rebuild(drift, speed + 0.25 * slide.abs(), skin - slip, dt, most)
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

    #[test]
    fn a_sheared_cell_rebuilds_before_its_slide_uses_the_skin() {
        // 0.4 mm skin, 0.1 mm slid: 0.15 mm margin; at rest, a slide of 10 m/s eats 5 µm a step.
        assert_eq!(steps_until_rebuild_sheared(0.0, 0.0, 0.4e-3, 1e-6, 1000, 0.1e-3, 10.0), Some(30));
        assert_eq!(steps_until_rebuild_sheared(0.0, 0.0, 0.4e-3, 1e-6, 1000, 0.4e-3, 10.0), None);
        // No slide: the plain rule.
        assert_eq!(steps_until_rebuild_sheared(0.0, 1.0, 0.4e-3, 1e-6, 1000, 0.0, 0.0), Some(100));
    }
}
