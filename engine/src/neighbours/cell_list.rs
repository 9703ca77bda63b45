//! The cell list behind a row build: every pair closer than the sum of its radii plus the
//! skin, found by its larger particle.

use crate::physics::Vec3;
use crate::state::particles::dof;
use rayon::prelude::*;

/// All pairs (i < j) closer than r_i + r_j + skin, neither of them killed (`fixed` has
/// [`dof::KILLED`]: a killed element is in no row).
pub(super) fn find_pairs(pos: &[Vec3], radius: &[f64], fixed: &[u8], skin: f64) -> Vec<(u32, u32)> {
    let killed = |i: usize| fixed[i] & dof::KILLED != 0;
    let n = pos.len();
    let (mut lo, mut hi) = (pos[0], pos[0]);
    for x in pos {
        lo = lo.inf(x);
        hi = hi.sup(x);
    }
    let r_mean = radius.iter().sum::<f64>() / n as f64;
    // Cells sized for the typical particle; bounded so a sparse scene stays small.
    let mut h = 2.0 * r_mean + skin;
    let ext = hi - lo;
    if !(ext.iter().all(|e| e.is_finite()) && h.is_finite() && h > 0.0) {
        // A diverging run (a particle flung to infinity): no grid fits it. The stability
        // guard reports the particle at the end of the chunk.
        return Vec::new();
    }
    let dims = loop {
        let cells = |e: f64| ((e / h) as usize).saturating_add(1);
        let d = [cells(ext.x), cells(ext.y), cells(ext.z)];
        if d[0].saturating_mul(d[1]).saturating_mul(d[2]) <= 4 * n + 64 {
            break d;
        }
        h *= 1.26;
    };
    let cell_of = |x: &Vec3| -> [usize; 3] {
        let c = (x - lo) / h;
        [(c.x as usize).min(dims[0] - 1), (c.y as usize).min(dims[1] - 1), (c.z as usize).min(dims[2] - 1)]
    };
    let flat = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
    let ncell = dims[0] * dims[1] * dims[2];
    let mut cell_start = vec![0u32; ncell + 1];
    let cells: Vec<usize> = pos.iter().map(|x| flat(cell_of(x))).collect();
    for &c in &cells {
        cell_start[c + 1] += 1;
    }
    for c in 0..ncell {
        cell_start[c + 1] += cell_start[c];
    }
    let mut fill = cell_start.clone();
    let mut items = vec![0u32; n];
    for (i, &c) in cells.iter().enumerate() {
        items[fill[c] as usize] = i as u32;
        fill[c] += 1;
    }
    let found: Vec<Vec<(u32, u32)>> = (0..n)
        .into_par_iter()
        .with_min_len(256)
        .map(|i| {
            let mut out = Vec::new();
            if killed(i) {
                return out;
            }
            let (xi, ri) = (pos[i], radius[i]);
            let reach = 2.0 * ri + skin;
            let k = (reach / h).ceil() as isize;
            let c = cell_of(&xi);
            let range = |a: usize, d: usize| {
                let a = a as isize;
                (a - k).max(0) as usize..=((a + k) as usize).min(d - 1)
            };
            for cz in range(c[2], dims[2]) {
                for cy in range(c[1], dims[1]) {
                    for cx in range(c[0], dims[0]) {
                        let cell = flat([cx, cy, cz]);
                        for &j in &items[cell_start[cell] as usize..cell_start[cell + 1] as usize] {
                            let j = j as usize;
                            let rj = radius[j];
                            // The larger particle (ties: the lower id) owns the pair.
                            if rj > ri || (rj == ri && j <= i) || killed(j) {
                                continue;
                            }
                            let cut = ri + rj + skin;
                            if (pos[j] - xi).norm_squared() < cut * cut {
                                out.push(((i.min(j)) as u32, (i.max(j)) as u32));
                            }
                        }
                    }
                }
            }
            out
        })
        .collect();
    found.into_iter().flatten().collect()
}
