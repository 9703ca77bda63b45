//! Neighbour rows by a cell list with a skin (Verlet lists), rebuilt only when some particle
//! has drifted more than half the skin since the last build.
//!
//! Each pair is found once, by its larger particle searching a reach of 2·r + skin, so a
//! wide gradation costs the small particles no more than a mono-size packing; the pairs
//! are then mirrored into both rows. Pair state is carried across rebuilds, and bonded
//! pairs stay in the rows however far apart they drift.

use crate::model::Model;
use crate::physics::contact_law::PairState;
use crate::physics::Vec3;
use crate::state::contacts::Contacts;
use rayon::prelude::*;

/// Rebuilds the model's rows for the current positions.
pub fn rebuild(m: &mut Model) {
    let p = &m.particles;
    let n = p.len();
    if m.contacts.skin <= 0.0 {
        m.contacts.skin = m.settings.skin_ratio * m.mean_radius();
    }
    let skin = m.contacts.skin;
    let mut pairs = if n == 0 { Vec::new() } else { find_pairs(&p.pos, &p.radius, skin) };
    // Keep bonded pairs whatever their distance.
    let old = &m.contacts;
    for i in 0..old.row_start.len().saturating_sub(1) {
        for e in old.row(i) {
            let j = old.other[e];
            if (i as u32) < j && old.state[e].bonded {
                pairs.push((i as u32, j));
            }
        }
    }
    pairs.par_sort_unstable();
    pairs.dedup();

    let mut row_start = vec![0u32; n + 1];
    for &(i, j) in &pairs {
        row_start[i as usize + 1] += 1;
        row_start[j as usize + 1] += 1;
    }
    for i in 0..n {
        row_start[i + 1] += row_start[i];
    }
    let mut fill = row_start.clone();
    let mut other = vec![0u32; pairs.len() * 2];
    // Pairs are sorted by (i, j): pushing j into row i and i into row j keeps rows sorted.
    for &(i, j) in &pairs {
        other[fill[i as usize] as usize] = j;
        fill[i as usize] += 1;
    }
    for &(i, j) in &pairs {
        other[fill[j as usize] as usize] = i;
        fill[j as usize] += 1;
    }
    for i in 0..n {
        other[row_start[i] as usize..row_start[i + 1] as usize].sort_unstable();
    }
    let state: Vec<PairState> = (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            let r = row_start[i] as usize..row_start[i + 1] as usize;
            other[r].iter().map(move |&j| old.find(i, j).map(|e| old.state[e]).unwrap_or_default())
        })
        .collect();
    m.contacts = Contacts {
        row_start,
        other,
        state,
        built_at: p.pos.clone(),
        skin,
        stale: false,
    };
}

/// All pairs (i < j) closer than r_i + r_j + skin.
fn find_pairs(pos: &[Vec3], radius: &[f64], skin: f64) -> Vec<(u32, u32)> {
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
    let dims = loop {
        let d = [
            (ext.x / h) as usize + 1,
            (ext.y / h) as usize + 1,
            (ext.z / h) as usize + 1,
        ];
        if d[0] * d[1] * d[2] <= 4 * n + 64 {
            break d;
        }
        h *= 1.26;
    };
    let cell_of = |x: &Vec3| -> [usize; 3] {
        let c = (x - lo) / h;
        [
            (c.x as usize).min(dims[0] - 1),
            (c.y as usize).min(dims[1] - 1),
            (c.z as usize).min(dims[2] - 1),
        ]
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
                            if rj > ri || (rj == ri && j <= i) {
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

/// Whether some particle moved more than half the skin since the rows were built.
pub fn is_stale(c: &Contacts, pos: &[Vec3]) -> bool {
    if c.stale || c.built_at.len() != pos.len() {
        return true;
    }
    let limit = 0.25 * c.skin * c.skin;
    let moved = |(a, b): (&Vec3, &Vec3)| (a - b).norm_squared() > limit;
    // Small models: waking the thread pool every step costs more than the check.
    if pos.len() < 16_384 {
        return pos.iter().zip(&c.built_at).any(moved);
    }
    pos.par_iter().zip(c.built_at.par_iter()).with_min_len(4096).any(moved)
}
