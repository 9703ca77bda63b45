//! Pore pressure on the grains. The fluid of a pore pushes on the part of each corner
//! sphere inside the pore's tetrahedra; by the divergence theorem that push equals the
//! pressure on the flat cuts of the sphere sector, i.e. on each face the sphere exposes its
//! circle sector θ_i r_i²/2, pushed along the face's outward normal. A face shared by two
//! tetrahedra of equal pressure therefore cancels exactly, so an element inside a uniformly
//! pressurised region feels no net force, and the hull faces carry p × (their sectors).
//! Each element exposes the sector, not the whole face: the face's opening is the throat,
//! where the fluid meets fluid.

use super::geometry::angle;
use super::network::{face_corners, PoreNetwork};
use crate::physics::Vec3;

/// Adds the pore-pressure force on every element to `force` (N). One pass over the
/// tetrahedra in order, so the sums do not depend on the thread count.
pub fn add_pressure_forces(net: &PoreNetwork, pressure: &[f64], pos: &[Vec3], rad: &[f64], force: &mut [Vec3]) {
    for (t, tet) in net.tri.tets.iter().enumerate() {
        let p = pressure[net.tet_pore[t] as usize];
        if p == 0.0 {
            continue;
        }
        for k in 0..4 {
            let f = face_corners(tet.v, k);
            let x = f.map(|i| pos[i as usize]);
            let mut n = (x[1] - x[0]).cross(&(x[2] - x[0]));
            let len = n.norm();
            if len == 0.0 {
                continue;
            }
            n /= len;
            // Which side is out comes from the points the tetrahedralisation was built on:
            // a tetrahedron that is flat in the real positions still has a definite side
            // there, and its neighbour sees the shared face from the other one, so the two
            // contributions cancel exactly.
            let j = f.map(|i| Vec3::from(net.tri.points[i as usize]));
            let apex = Vec3::from(net.tri.points[tet.v[k] as usize]);
            if (j[1] - j[0]).cross(&(j[2] - j[0])).dot(&(apex - j[0])) > 0.0 {
                n = -n;
            }
            for c in 0..3 {
                let r = rad[f[c] as usize];
                let sector = 0.5 * angle(x[c], x[(c + 1) % 3], x[(c + 2) % 3]) * r * r;
                force[f[c] as usize] += n * (p * sector);
            }
        }
    }
}
