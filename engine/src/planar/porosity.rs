//! A 2D model's porosity: by area in its plane, the discs of its elements against the region's
//! cut by y = 0.

use super::area::disc_rectangle_area;
use crate::geometry::region::Region;
use crate::model::Model;
use crate::physics::Vec3;

/// The region's cut by the plane y = 0: a rectangle for a box or a vertical cylinder, a disc
/// for a sphere.
enum Section {
    Rectangle { x: (f64, f64), z: (f64, f64) },
    Disc { cx: f64, cz: f64, r: f64 },
}

fn section(region: &Region) -> Section {
    let empty = Section::Rectangle { x: (0.0, 0.0), z: (0.0, 0.0) };
    match *region {
        Region::Box { lo, hi } if lo.y <= 0.0 && hi.y >= 0.0 => Section::Rectangle { x: (lo.x, hi.x), z: (lo.z, hi.z) },
        Region::Cylinder { center, radius, z0, z1 } if center.y.abs() <= radius => {
            let w = (radius * radius - center.y * center.y).sqrt();
            Section::Rectangle { x: (center.x - w, center.x + w), z: (z0, z1) }
        }
        Region::Sphere { center, radius } if center.y.abs() <= radius => {
            Section::Disc { cx: center.x, cz: center.z, r: (radius * radius - center.y * center.y).sqrt() }
        }
        _ => empty,
    }
}

/// The area of the region's cut by the plane y = 0 (m²).
pub fn section_area(region: &Region) -> f64 {
    match section(region) {
        Section::Rectangle { x, z } => (x.1 - x.0).max(0.0) * (z.1 - z.0).max(0.0),
        Section::Disc { r, .. } => std::f64::consts::PI * r * r,
    }
}

/// The area two discs share (m²).
fn lens_area(d: f64, r: f64, s: f64) -> f64 {
    use std::f64::consts::PI;
    if d >= r + s {
        return 0.0;
    }
    if d <= (r - s).abs() {
        return PI * r.min(s).powi(2);
    }
    let a = r * r * ((d * d + r * r - s * s) / (2.0 * d * r)).clamp(-1.0, 1.0).acos();
    let b = s * s * ((d * d + s * s - r * r) / (2.0 * d * s)).clamp(-1.0, 1.0).acos();
    let k = ((-d + r + s) * (d + r - s) * (d - r + s) * (d + r + s)).max(0.0).sqrt();
    a + b - 0.5 * k
}

/// A 2D model's porosity in a region by area: 1 − (the area the elements' discs share with
/// the region's cut by y = 0) / that cut's area, exact for discs cut by the region's edges.
/// In a periodic cell, with the parts of discs that reach the region through the faces.
pub fn porosity_by_area(m: &Model, region: &Region) -> f64 {
    let p = &m.particles;
    let cut = section(region);
    let shifts = m.effects.periodic.cell.map_or_else(|| vec![Vec3::zeros()], |c| c.image_shifts());
    let area = |c: Vec3, r: f64| match cut {
        Section::Rectangle { x, z } => disc_rectangle_area(c.x, c.z, r, x, z),
        Section::Disc { cx, cz, r: s } => lens_area(((c.x - cx).powi(2) + (c.z - cz).powi(2)).sqrt(), r, s),
    };
    let solid: f64 = (0..p.len())
        .filter(|&i| !m.is_killed(i))
        .map(|i| shifts.iter().map(|s| area(p.pos[i] + s, p.radius[i])).sum::<f64>())
        .sum();
    let a = section_area(region);
    if a > 0.0 {
        1.0 - solid / a
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn two_discs_share_a_lens_that_grows_from_nothing_to_the_smaller_disc() {
        assert_eq!(lens_area(3.0, 1.0, 2.0), 0.0);
        assert!((lens_area(0.5, 1.0, 2.0) - PI).abs() < 1e-15);
        // Equal discs at distance r: 2r²·acos(1/2) − (r/2)·√3·r.
        let exact = 2.0 * (0.5f64).acos() - 0.5 * 3f64.sqrt();
        assert!((lens_area(1.0, 1.0, 1.0) - exact).abs() < 1e-14);
    }
}
