//! Pore pressure on the grains. The fluid of each pore pushes the corners of its tetrahedra
//! apart: element i at a corner of tetrahedron t gets p_t·∂V_t/∂x_i, the gradient of the
//! tetrahedron's volume with respect to that corner (a third of the opposite face's area
//! along its inward normal; equivalently, a third of each of its three faces through i,
//! along their outward normals). This is the force conjugate to the fluid's work p·dV, so:
//!
//! - a face shared by two tetrahedra of equal pressure cancels exactly, and an element inside
//!   a uniformly pressurised region feels no net force; the hull faces carry p × their whole
//!   area, shared equally by their three corners (a membrane on the hull: the pressure reaches
//!   walls through the grains);
//! - across a face between pores at p_a and p_b the grains carry (p_a − p_b) × the whole face
//!   area: the sector the spheres cut from the face (the pressure on the grain's surface) and
//!   the throat's opening (the seepage drag the flow through the throat exerts on its walls).
//!   The skeleton therefore carries the whole pressure gradient (Biot's coefficient 1, grains
//!   incompressible), as Terzaghi's effective stress σ' = σ − u assumes.
//!
//! Each element sums its own corners ([`PoreNetwork::elem_corners`], in tetrahedron order):
//! no atomics, the same bits whatever the thread count.

use super::network::PoreNetwork;
use crate::physics::Vec3;
use rayon::prelude::*;

/// The corners of a tetrahedron listed from corner `c` by an even permutation, so that
/// V = (x_c − x_3)·((x_1 − x_3) × (x_2 − x_3))/6 keeps its sign.
const EVEN: [[usize; 4]; 4] = [[0, 1, 2, 3], [1, 0, 3, 2], [2, 3, 0, 1], [3, 2, 1, 0]];

/// ∂V/∂x of corner `c` of the tetrahedron with corners `v` (signed volume as `tet_volume`).
#[inline]
pub fn volume_gradient(pos: &[Vec3], v: [u32; 4], c: usize) -> Vec3 {
    let e = EVEN[c];
    let x = |k: usize| pos[v[e[k]] as usize];
    (x(1) - x(3)).cross(&(x(2) - x(3))) / 6.0
}

/// The pore-pressure force on element `i` (N).
#[inline]
pub fn pressure_force(net: &PoreNetwork, pressure: &[f64], pos: &[Vec3], i: usize) -> Vec3 {
    let mut f = Vec3::zeros();
    for &e in &net.elem_corners[net.elem_start[i] as usize..net.elem_start[i + 1] as usize] {
        let (t, c) = ((e / 4) as usize, (e % 4) as usize);
        let p = pressure[net.tet_pore[t] as usize];
        if p != 0.0 {
            f += volume_gradient(pos, net.tri.tets[t].v, c) * (p * net.orient[t]);
        }
    }
    f
}

/// Adds the pore-pressure force on every element to `force` (N), each element gathering its
/// own corners in parallel.
pub fn add_pressure_forces(net: &PoreNetwork, pressure: &[f64], pos: &[Vec3], force: &mut [Vec3]) {
    force.par_iter_mut().enumerate().for_each(|(i, f)| {
        if i + 1 < net.elem_start.len() {
            *f += pressure_force(net, pressure, pos, i);
        }
    });
}
