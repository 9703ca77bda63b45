//! The cell list behind a row build: every pair closer than the sum of its radii plus the
//! skin, found by its larger particle.

use crate::effects::periodic::Periodic;
use crate::physics::Vec3;
use crate::state::particles::dof;
use rayon::prelude::*;

/// All pairs (i < j) closer than r_i + r_j + skin, neither of them killed (`fixed` has
/// [`dof::KILLED`]: a killed element is in no row). In a periodic `cell`, distances are to the
/// nearest image and the cells wrap round the periodic axes (a pair may come out twice where
/// the cells are few: the caller sorts and dedups).
pub(super) fn find_pairs(
    pos: &[Vec3],
    radius: &[f64],
    fixed: &[u8],
    skin: f64,
    cell: Option<&Periodic>,
) -> Vec<(u32, u32)> {
    let killed = |i: usize| fixed[i] & dof::KILLED != 0;
    let n = pos.len();
    let (mut lo, mut hi) = (pos[0], pos[0]);
    for x in pos {
        lo = lo.inf(x);
        hi = hi.sup(x);
    }
    let wraps: [bool; 3] = std::array::from_fn(|k| cell.is_some_and(|c| c.axes[k].is_some()));
    if let Some(c) = cell {
        for (k, axis) in c.axes.iter().enumerate() {
            if let Some([a, b]) = *axis {
                (lo[k], hi[k]) = (a, b);
            }
        }
    }
    let image = cell.map(Periodic::image);
    let sheared = cell.is_some_and(|c| c.shear.is_some());
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
        // A periodic axis is cut into whole cells of at least h, so they tile its span.
        let cells = |k: usize| match wraps[k] {
            true => ((ext[k] / h) as usize).max(1),
            false => ((ext[k] / h) as usize).saturating_add(1),
        };
        let d = [cells(0), cells(1), cells(2)];
        if d[0].saturating_mul(d[1]).saturating_mul(d[2]) <= 4 * n + 64 {
            break d;
        }
        h *= 1.26;
    };
    let width: [f64; 3] = std::array::from_fn(|k| if wraps[k] { ext[k] / dims[k] as f64 } else { h });
    let cell_of = |x: &Vec3| -> [usize; 3] {
        std::array::from_fn(|k| {
            // Floored: a clump's member may reach below a periodic axis's lower face.
            let c = ((x[k] - lo[k]) / width[k]).floor() as isize;
            if wraps[k] {
                c.rem_euclid(dims[k] as isize) as usize
            } else {
                (c.max(0) as usize).min(dims[k] - 1)
            }
        })
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
            let c = cell_of(&xi);
            // The cells within reach along axis a: clamped to the grid, or round it where the
            // axis is periodic (each cell once, however far the reach).
            // The cells within reach along axis a: clamped to the grid, or round it where the
            // axis is periodic (each cell once, however far the reach); every cell when `all`.
            let range = |a: usize, all: bool| {
                let (d, k, at) = (dims[a] as isize, (reach / width[a]).ceil() as isize, c[a] as isize);
                let (first, last) = match wraps[a] {
                    true if all || 2 * k + 1 >= d => (0, d - 1),
                    true => (at - k, at + k),
                    false => ((at - k).max(0), (at + k).min(d - 1)),
                };
                let wrap = wraps[a];
                (first..=last).map(move |x| if wrap { x.rem_euclid(d) as usize } else { x as usize })
            };
            let (z_at, z_reach) = (c[2] as isize, (reach / width[2]).ceil() as isize);
            let z_all = 2 * z_reach + 1 >= dims[2] as isize;
            for cz in range(2, false) {
                // Under Lees–Edwards shear the cells across a z face hold the images slid along
                // x by the offset: look along the whole row there (a visited cell farther than
                // the reach from i's own was reached round the face).
                let across = sheared && (z_all || (cz as isize - z_at).abs() > z_reach);
                for cy in range(1, false) {
                    for cx in range(0, across) {
                        let cell = flat([cx, cy, cz]);
                        for &j in &items[cell_start[cell] as usize..cell_start[cell + 1] as usize] {
                            let j = j as usize;
                            let rj = radius[j];
                            // The larger particle (ties: the lower id) owns the pair.
                            if rj > ri || (rj == ri && j <= i) || killed(j) {
                                continue;
                            }
                            let cut = ri + rj + skin;
                            let d = match &image {
                                Some(im) => im.nearest(pos[j] - xi),
                                None => pos[j] - xi,
                            };
                            if d.norm_squared() < cut * cut {
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
