//! The pore geometry of one tetrahedron of element centres: how much of it the four spheres
//! fill, how wide each face leaves the passage between two pores, and the Poiseuille-type
//! conductance of that passage. Pure functions over positions and radii.

use crate::physics::Vec3;

/// Solid angle (sr) subtended at `a` by the triangle `b, c, d` (Van Oosterom–Strackee):
/// tan(Ω/2) = |u·(v×w)| / (|u||v||w| + (u·v)|w| + (u·w)|v| + (v·w)|u|), u = b−a, ….
pub fn solid_angle(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f64 {
    let (u, v, w) = (b - a, c - a, d - a);
    let (lu, lv, lw) = (u.norm(), v.norm(), w.norm());
    let num = u.dot(&v.cross(&w)).abs();
    let den = lu * lv * lw + u.dot(&v) * lw + u.dot(&w) * lv + v.dot(&w) * lu;
    2.0 * num.atan2(den)
}

/// Angle (rad) at `a` between the edges to `b` and `c`.
pub fn angle(a: Vec3, b: Vec3, c: Vec3) -> f64 {
    let (u, v) = (b - a, c - a);
    u.cross(&v).norm().atan2(u.dot(&v))
}

/// The part of a tetrahedron the spheres at its corners leave empty: its volume minus the
/// four sphere sectors, Σ Ω_i r_i³ / 3 (Ω_i the solid angle at corner i). Overlapping
/// spheres would be subtracted twice; the result is kept above `floor` × the tetrahedron's
/// volume so that a tightly packed pore keeps a little room.
pub fn pore_volume(v: [Vec3; 4], r: [f64; 4], floor: f64) -> f64 {
    let tet = tet_volume(v).abs();
    (tet - sectors_volume(v, r)).max(floor * tet)
}

/// The volume of the four sphere sectors in a tetrahedron, Σ min(Ω_i r_i³ / 3, V): a
/// sector lies inside the tetrahedron while its sphere stays short of the opposite face, and
/// then never exceeds it; one that is larger reaches through that face, and of a flat
/// tetrahedron (a sliver on the hull, Ω → 2π at a corner inside the others' triangle) would
/// subtract a hemisphere of room that lies outside the packing.
pub fn sectors_volume(v: [Vec3; 4], r: [f64; 4]) -> f64 {
    let tet = tet_volume(v).abs();
    let mut solid = 0.0;
    for i in 0..4 {
        let o = [v[(i + 1) % 4], v[(i + 2) % 4], v[(i + 3) % 4]];
        solid += (solid_angle(v[i], o[0], o[1], o[2]) * r[i].powi(3) / 3.0).min(tet);
    }
    solid
}

/// Signed volume, positive when det[a−d, b−d, c−d] > 0 (the tetrahedralisation's orientation).
pub fn tet_volume(v: [Vec3; 4]) -> f64 {
    let [a, b, c, d] = v;
    (a - d).dot(&(b - d).cross(&(c - d))) / 6.0
}

/// The passage a triangular face leaves between the three circles the spheres cut from
/// its plane: the triangle's area minus the three circle sectors θ_i r_i²/2 (the opening,
/// m², never below 0), and the wetted perimeter Σ θ_i r_i (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Opening {
    pub area: f64,
    pub perimeter: f64,
    /// The triangle's full area (m²).
    pub face: f64,
    /// The sector each corner's sphere covers, θ_i r_i²/2 (m²).
    pub sectors: [f64; 3],
}

pub fn opening(v: [Vec3; 3], r: [f64; 3]) -> Opening {
    let face = 0.5 * (v[1] - v[0]).cross(&(v[2] - v[0])).norm();
    let mut sectors = [0.0; 3];
    let mut perimeter = 0.0;
    for i in 0..3 {
        let th = angle(v[i], v[(i + 1) % 3], v[(i + 2) % 3]);
        sectors[i] = 0.5 * th * r[i] * r[i];
        perimeter += th * r[i];
    }
    let area = (face - sectors.iter().sum::<f64>()).max(0.0);
    Opening { area, perimeter, face, sectors }
}

/// Poiseuille-type conductance of a throat (m³/(Pa·s)): volumetric flow per pressure
/// difference, g = A·R_h² / (2·μ·L), with A the opening, R_h = A / P its hydraulic radius
/// and L the distance between the two pore centres. For a circular tube (R_h = r/2) this is
/// exactly Poiseuille's π r⁴ / (8 μ L).
pub fn poiseuille(open: &Opening, viscosity: f64, length: f64) -> f64 {
    if open.area <= 0.0 || open.perimeter <= 0.0 {
        return 0.0;
    }
    let rh = open.area / open.perimeter;
    open.area * rh * rh / (2.0 * viscosity * length)
}

/// As [`poiseuille`], with the hydraulic radius at most `thickness`: a passage between
/// two flat pores (thin slabs of fluid, as the convex hull's slivers are) is no wider than the
/// pores it joins, however large the face between them.
pub fn poiseuille_within(open: &Opening, thickness: f64, viscosity: f64, length: f64) -> f64 {
    if open.area <= 0.0 || open.perimeter <= 0.0 {
        return 0.0;
    }
    let rh = (open.area / open.perimeter).min(thickness);
    open.area * rh * rh / (2.0 * viscosity * length)
}

/// Parallel-plate (cubic-law) conductance of a crack of aperture `w` and width `b` over a
/// length `l`: w³·b / (12 μ l).
pub fn cubic_law(aperture: f64, width: f64, viscosity: f64, length: f64) -> f64 {
    aperture.powi(3) * width / (12.0 * viscosity * length)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angle_of_a_cube_corner_is_an_eighth_of_the_sphere() {
        let o = Vec3::zeros();
        let om = solid_angle(o, Vec3::x(), Vec3::y(), Vec3::z());
        assert!((om - std::f64::consts::PI / 2.0).abs() < 1e-14, "{om}");
    }

    #[test]
    fn solid_angles_of_a_regular_tetrahedron_add_up_to_four_times_its_corner() {
        // Regular tetrahedron corner: Ω = arccos(23/27).
        let v = [
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(-1.0, -1.0, 1.0),
        ];
        let om = solid_angle(v[0], v[1], v[2], v[3]);
        assert!((om - (23.0f64 / 27.0).acos()).abs() < 1e-14, "{om}");
    }

    #[test]
    fn opening_of_three_touching_equal_circles_is_the_classic_gap() {
        // Equilateral triangle of side 2r, circles of radius r: gap = (√3 − π/2) r².
        let r = 0.5;
        let v = [Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.5, 3f64.sqrt() / 2.0, 0.0)];
        let o = opening(v, [r; 3]);
        let want = (3f64.sqrt() - std::f64::consts::FRAC_PI_2) * r * r;
        assert!((o.area - want).abs() < 1e-14, "{} vs {want}", o.area);
        assert!((o.perimeter - std::f64::consts::PI * r).abs() < 1e-14);
    }

    #[test]
    fn poiseuille_law_matches_a_circular_tube() {
        // A circle of radius a: A = π a², P = 2π a.
        let a = 1e-3;
        let o = Opening {
            area: std::f64::consts::PI * a * a,
            perimeter: 2.0 * std::f64::consts::PI * a,
            face: 0.0,
            sectors: [0.0; 3],
        };
        let g = poiseuille(&o, 1e-3, 0.1);
        let want = std::f64::consts::PI * a.powi(4) / (8.0 * 1e-3 * 0.1);
        assert!((g / want - 1.0).abs() < 1e-12);
    }
}
