//! Surfaces from scattered points (MatDEM's `Tool_Cut` surfaces): a terrain, a layer
//! boundary or a joint given as (x, y, z) points, triangulated in plan view (2-D Delaunay)
//! and interpolated linearly in each triangle, so a surface is a height z = h(x, y).
//!
//! Outside the points' convex hull the surface continues at the height of the nearest
//! point of the hull (linear along its edge), so it covers the whole plan of any model and
//! "above" and "below" are defined for every element. Vertical faces (a cliff, a tunnel
//! wall) are not heights: cut those with regions (`in_cylinder`, `in_polygon`).

use crate::error::{Error, Result};
use crate::physics::Vec3;
use spade::{DelaunayTriangulation, FloatTriangulation, HasPosition, Point2, Triangulation};

/// One of the surface's points: its plan position and its height.
#[derive(Debug, Clone, Copy)]
struct Sample {
    at: Point2<f64>,
    z: f64,
}

impl HasPosition for Sample {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.at
    }
}

/// A height field z = h(x, y) through scattered points.
#[derive(Debug, Clone)]
pub struct Surface {
    tri: DelaunayTriangulation<Sample>,
    /// The convex hull's edges as ((x, y, z), (x, y, z)), for heights outside it.
    hull: Vec<(Vec3, Vec3)>,
}

impl Surface {
    /// The surface through `points`. Refuses fewer than three points, a non-finite
    /// coordinate, two points at the same (x, y) and points that all lie on one line in
    /// plan, naming the points.
    pub fn from_points(points: &[Vec3]) -> Result<Self> {
        if points.len() < 3 {
            return Err(Error::InvalidScene(format!(
                "a surface needs at least 3 points not on one line in plan (x, y), got {}",
                points.len()
            )));
        }
        if let Some(k) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            let p = points[k];
            return Err(Error::InvalidScene(format!(
                "surface point {k} is ({}, {}, {}); every coordinate must be a finite number",
                p.x, p.y, p.z
            )));
        }
        let mut seen = std::collections::HashMap::with_capacity(points.len());
        for (k, p) in points.iter().enumerate() {
            // +0.0 so that -0.0 and 0.0 are one position.
            if let Some(first) = seen.insert(((p.x + 0.0).to_bits(), (p.y + 0.0).to_bits()), k) {
                return Err(Error::InvalidScene(format!(
                    "surface points {first} and {k} are both at (x, y) = ({}, {}): a surface has one height per \
                     plan position; remove one of them",
                    p.x, p.y
                )));
            }
        }
        let mut tri = DelaunayTriangulation::<Sample>::new();
        for (k, p) in points.iter().enumerate() {
            tri.insert(Sample { at: Point2::new(p.x, p.y), z: p.z })
                .map_err(|e| Error::InvalidScene(format!("surface point {k} cannot be triangulated: {e:?}")))?;
        }
        if tri.num_inner_faces() == 0 {
            return Err(Error::InvalidScene(
                "the surface's points all lie on one line in plan (x, y): give points that span an area".into(),
            ));
        }
        let hull = tri
            .convex_hull()
            .map(|e| {
                let (a, b) = (e.from(), e.to());
                let v = |p: Point2<f64>, z: f64| Vec3::new(p.x, p.y, z);
                (v(a.position(), a.data().z), v(b.position(), b.data().z))
            })
            .collect();
        Ok(Surface { tri, hull })
    }

    /// The height at plan position (x, y): linear in the triangle holding it, or the height
    /// of the nearest point of the hull outside the points' convex hull.
    pub fn height(&self, x: f64, y: f64) -> f64 {
        let inside = self.tri.barycentric().interpolate(|v| v.data().z, Point2::new(x, y));
        inside.unwrap_or_else(|| self.hull_height(x, y))
    }

    fn hull_height(&self, x: f64, y: f64) -> f64 {
        let mut best = (f64::INFINITY, 0.0);
        for (a, b) in &self.hull {
            let (ex, ey) = (b.x - a.x, b.y - a.y);
            let len2 = ex * ex + ey * ey;
            let t = if len2 > 0.0 { (((x - a.x) * ex + (y - a.y) * ey) / len2).clamp(0.0, 1.0) } else { 0.0 };
            let (px, py) = (a.x + t * ex, a.y + t * ey);
            let d2 = (x - px).powi(2) + (y - py).powi(2);
            if d2 < best.0 {
                best = (d2, a.z + t * (b.z - a.z));
            }
        }
        best.1
    }

    /// Whether `p` lies strictly above the surface.
    pub fn is_above(&self, p: &Vec3) -> bool {
        p.z > self.height(p.x, p.y)
    }

    /// The number of points the surface was made from.
    pub fn points(&self) -> usize {
        self.tri.num_vertices()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_through_scattered_points_is_reproduced_inside_and_continued_outside() {
        let plane = |x: f64, y: f64| 0.3 * x - 0.2 * y + 1.0;
        let pts: Vec<Vec3> = [(0.0, 0.0), (1.0, 0.1), (0.2, 1.0), (0.9, 0.8), (0.5, 0.4), (0.1, 0.6)]
            .iter()
            .map(|&(x, y)| Vec3::new(x, y, plane(x, y)))
            .collect();
        let s = Surface::from_points(&pts).unwrap();
        for (x, y) in [(0.5, 0.5), (0.3, 0.2), (0.8, 0.7)] {
            assert!((s.height(x, y) - plane(x, y)).abs() < 1e-12, "({x}, {y})");
        }
        // Outside: the hull's nearest point, here the vertex (0, 0) itself.
        assert!((s.height(-1.0, -1.0) - 1.0).abs() < 1e-12);
        assert!(s.is_above(&Vec3::new(0.5, 0.5, 2.0)) && !s.is_above(&Vec3::new(0.5, 0.5, 0.0)));
    }

    #[test]
    fn degenerate_point_sets_are_refused_by_name() {
        let line: Vec<Vec3> = (0..4).map(|k| Vec3::new(k as f64, 2.0 * k as f64, 0.0)).collect();
        assert!(Surface::from_points(&line).unwrap_err().to_string().contains("one line"));
        let twin = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 5.0)];
        assert!(Surface::from_points(&twin).unwrap_err().to_string().contains("points 1 and 2"));
        assert!(Surface::from_points(&twin[..2]).is_err());
    }
}
