//! Regions of space a statistic or a measurement reads: boxes, vertical cylinders, spheres,
//! with the exact volume a sphere shares with each.

use super::sphere_box::{sphere_box_volume, sphere_cylinder_volume, sphere_sphere_volume};
use crate::physics::Vec3;

/// A region for porosity and void ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    Box {
        lo: Vec3,
        hi: Vec3,
    },
    /// Vertical cylinder between `z0` and `z1`.
    Cylinder {
        center: Vec3,
        radius: f64,
        z0: f64,
        z1: f64,
    },
    /// A sphere (added for `analysis::measure`).
    Sphere {
        center: Vec3,
        radius: f64,
    },
}

impl Region {
    pub fn contains(&self, x: &Vec3) -> bool {
        match self {
            Region::Box { lo, hi } => (0..3).all(|k| x[k] >= lo[k] && x[k] <= hi[k]),
            Region::Cylinder { center, radius, z0, z1 } => {
                let (dx, dy) = (x.x - center.x, x.y - center.y);
                dx * dx + dy * dy <= radius * radius && x.z >= *z0 && x.z <= *z1
            }
            Region::Sphere { center, radius } => (x - center).norm_squared() <= radius * radius,
        }
    }

    pub fn volume(&self) -> f64 {
        match self {
            Region::Box { lo, hi } => (hi - lo).iter().map(|d| d.max(0.0)).product(),
            Region::Cylinder { radius, z0, z1, .. } => std::f64::consts::PI * radius * radius * (z1 - z0).max(0.0),
            Region::Sphere { radius, .. } => crate::geometry::sphere_box::sphere_volume(*radius),
        }
    }
}

impl Region {
    /// The share (0 to 1) of the segment from `a` to `b` that lies inside the region: a
    /// contact's branch vector cut by the region's boundary counts by it
    /// (`analysis::measure`).
    pub fn segment_share(&self, a: Vec3, b: Vec3) -> f64 {
        let d = b - a;
        // The parameter interval [t0, t1] ⊂ [0, 1] of the points a + t·d inside.
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        // Keeps the part of the interval where lo ≤ s + t·ds ≤ hi.
        let mut clip = |s: f64, ds: f64, lo: f64, hi: f64| {
            if ds == 0.0 {
                if s < lo || s > hi {
                    t1 = -1.0;
                }
            } else {
                let (u, v) = ((lo - s) / ds, (hi - s) / ds);
                t0 = t0.max(u.min(v));
                t1 = t1.min(u.max(v));
            }
        };
        // Keeps the part where |q + t·dq|² ≤ r² (q, dq in the plane of the circle or in 3-D).
        let within = |q: Vec3, dq: Vec3, r: f64| -> Option<(f64, f64)> {
            let (aa, bb, cc) = (dq.norm_squared(), q.dot(&dq), q.norm_squared() - r * r);
            if aa == 0.0 {
                return (cc <= 0.0).then_some((f64::NEG_INFINITY, f64::INFINITY));
            }
            let disc = bb * bb - aa * cc;
            if disc < 0.0 {
                return None;
            }
            let root = disc.sqrt();
            Some(((-bb - root) / aa, (-bb + root) / aa))
        };
        match self {
            Region::Box { lo, hi } => {
                for k in 0..3 {
                    clip(a[k], d[k], lo[k], hi[k]);
                }
            }
            Region::Cylinder { center, radius, z0, z1 } => {
                clip(a.z, d.z, *z0, *z1);
                let q = Vec3::new(a.x - center.x, a.y - center.y, 0.0);
                match within(q, Vec3::new(d.x, d.y, 0.0), *radius) {
                    Some((u, v)) => (t0, t1) = (t0.max(u), t1.min(v)),
                    None => t1 = -1.0,
                }
            }
            Region::Sphere { center, radius } => match within(a - center, d, *radius) {
                Some((u, v)) => (t0, t1) = (t0.max(u), t1.min(v)),
                None => t1 = -1.0,
            },
        }
        (t1 - t0).max(0.0)
    }

    /// The volume the sphere at `c` of radius `r` shares with the region (m³).
    pub fn shared_volume(&self, c: Vec3, r: f64) -> f64 {
        match self {
            Region::Box { lo, hi } => sphere_box_volume(c, r, *lo, *hi),
            Region::Cylinder { center, radius, z0, z1 } => sphere_cylinder_volume(c, r, *center, *radius, *z0, *z1),
            Region::Sphere { center, radius } => sphere_sphere_volume(c, r, *center, *radius),
        }
    }
}
