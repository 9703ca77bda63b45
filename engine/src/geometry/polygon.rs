//! Polygon prisms (a region of MatDEM's `Tool_Cut`): the elements whose centre lies inside
//! a polygon in plan (x, y) and between two heights, e.g. the outline of a building
//! foundation or a quarry pit.

use crate::error::{Error, Result};
use crate::physics::Vec3;

/// A simple polygon in plan, its vertices in order (either direction), closed implicitly.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    xy: Vec<(f64, f64)>,
}

impl Polygon {
    /// Refuses fewer than three vertices and non-finite coordinates, naming the vertex, and
    /// a polygon of zero area.
    pub fn new(xy: Vec<(f64, f64)>) -> Result<Self> {
        if xy.len() < 3 {
            return Err(Error::InvalidScene(format!("a polygon needs at least 3 vertices, got {}", xy.len())));
        }
        if let Some(k) = xy.iter().position(|(x, y)| !(x.is_finite() && y.is_finite())) {
            return Err(Error::InvalidScene(format!(
                "polygon vertex {k} is ({}, {}); coordinates must be finite numbers",
                xy[k].0, xy[k].1
            )));
        }
        let p = Polygon { xy };
        if p.area() == 0.0 {
            return Err(Error::InvalidScene("the polygon has zero area (its vertices lie on one line)".into()));
        }
        Ok(p)
    }

    /// Area in plan (shoelace formula), m².
    pub fn area(&self) -> f64 {
        let n = self.xy.len();
        let twice: f64 = (0..n)
            .map(|k| {
                let ((x0, y0), (x1, y1)) = (self.xy[k], self.xy[(k + 1) % n]);
                x0 * y1 - x1 * y0
            })
            .sum();
        0.5 * twice.abs()
    }

    /// Whether (x, y) is inside (even–odd rule: a ray to +x crosses the outline an odd
    /// number of times). Points exactly on an edge may fall on either side.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let n = self.xy.len();
        let mut inside = false;
        for k in 0..n {
            let ((xi, yi), (xj, yj)) = (self.xy[k], self.xy[(k + n - 1) % n]);
            if (yi > y) != (yj > y) && x < xi + (y - yi) * (xj - xi) / (yj - yi) {
                inside = !inside;
            }
        }
        inside
    }

    /// Whether `p` is inside the prism over the polygon between heights `z0` and `z1`.
    pub fn prism_contains(&self, p: &Vec3, z0: f64, z1: f64) -> bool {
        p.z >= z0 && p.z <= z1 && self.contains(p.x, p.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_l_shape_holds_its_inside_and_not_its_notch() {
        let l = Polygon::new(vec![(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]).unwrap();
        assert_eq!(l.area(), 3.0);
        assert!(l.contains(0.5, 1.5) && l.contains(1.5, 0.5));
        assert!(!l.contains(1.5, 1.5) && !l.contains(-0.1, 0.5));
        assert!(Polygon::new(vec![(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]).is_err());
    }
}
