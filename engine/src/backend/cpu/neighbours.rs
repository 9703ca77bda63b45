//! Neighbour rows by a cell list with a skin (Verlet lists), rebuilt only when some particle
//! has drifted more than half the skin since the last build.
//!
//! Each pair is found once, by its larger particle searching a reach of 2·r + skin, so a
//! wide gradation costs the small particles no more than a mono-size packing; the pairs
//! are then mirrored into both rows. Pair state is carried across rebuilds, and bonded
//! pairs stay in the rows however far apart they drift.
//!
//! Walls get the same treatment: each particle carries a mask of the walls it may touch
//! before the next rebuild, rebuilt alone when only a wall has moved.

use crate::model::Model;
use crate::physics::contact_law::PairState;
use crate::physics::Vec3;
use crate::state::contacts::Contacts;
use crate::walls::{Wall, WallShape};
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
    let mut pair = vec![0u32; pairs.len() * 2];
    let mut pair_start = vec![0u32; n + 1];
    // Pairs are sorted by (i, j). Row j first takes its lower-id neighbours i, in ascending
    // order, then row i its higher-id ones j, also ascending: every row comes out sorted,
    // and each particle's own pairs (ids in `pairs` order) end its row.
    for (p, &(i, j)) in pairs.iter().enumerate() {
        let e = fill[j as usize] as usize;
        other[e] = i;
        pair[e] = p as u32;
        fill[j as usize] += 1;
    }
    for (p, &(i, j)) in pairs.iter().enumerate() {
        let e = fill[i as usize] as usize;
        other[e] = j;
        pair[e] = p as u32;
        fill[i as usize] += 1;
        pair_start[i as usize + 1] += 1;
    }
    for i in 0..n {
        pair_start[i + 1] += pair_start[i];
    }
    debug_assert!((0..n).all(|i| other[row_start[i] as usize..row_start[i + 1] as usize].is_sorted()));
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
        pair,
        pair_start,
        wall_near: Vec::new(),
        walls_at_build: Vec::new(),
        built_at: p.pos.clone(),
        skin,
        stale: false,
    };
    rebuild_wall_mask(m);
}

/// Margin of the wall mask beyond touching, in skins. Between two mask builds a particle
/// moves at most one skin from where the mask saw it (half a skin from the rows' build
/// positions, which may be half a skin from the mask's) and a wall half a skin: 1.5 would
/// do; 2 leaves room for round-off.
const WALL_MARGIN_SKINS: f64 = 2.0;

/// Rebuilds each particle's mask of the walls it may touch, for the current positions.
pub fn rebuild_wall_mask(m: &mut Model) {
    let (p, walls, c) = (&m.particles, &m.walls, &mut m.contacts);
    let nw = walls.len();
    let reach = WALL_MARGIN_SKINS * c.skin;
    let states = &m.wall_contacts;
    let mask_of = |i: usize| -> u8 {
        let mut bits = 0u8;
        for (w, wall) in walls.iter().enumerate() {
            let (_, gap) = wall.normal_and_distance(&p.pos[i]);
            // Keep a wall whose state is set even when far: the next wall pass must see
            // the contact open and release it.
            let set = states.get(i * nw + w).is_some_and(|st| st.shear != Vec3::zeros() || st.dashpot != 0.0);
            if gap < p.radius[i] + reach || set || !gap.is_finite() {
                bits |= 1 << w;
            }
        }
        bits
    };
    c.wall_near.clear();
    if nw > 0 {
        (0..p.len()).into_par_iter().with_min_len(4096).map(mask_of).collect_into_vec(&mut c.wall_near);
    } else {
        c.wall_near.resize(p.len(), 0);
    }
    c.walls_at_build = walls.iter().map(|w| w.shape.clone()).collect();
}

/// Whether the wall mask no longer covers the walls: one was added, removed, reshaped, or
/// has moved more than half the skin since the mask was built.
pub fn walls_stale(c: &Contacts, walls: &[Wall], particles: usize) -> bool {
    if c.wall_near.len() != particles || c.walls_at_build.len() != walls.len() {
        return true;
    }
    let limit = 0.5 * c.skin;
    walls.iter().zip(&c.walls_at_build).any(|(w, old)| {
        let moved = match (&w.shape, old) {
            (WallShape::Plane { point, normal }, WallShape::Plane { point: p0, normal: n0 }) if normal == n0 => {
                (point - p0).norm()
            }
            (WallShape::Cylinder { center, radius }, WallShape::Cylinder { center: c0, radius: r0 }) => {
                (center - c0).xy().norm() + (radius - r0).abs()
            }
            _ => f64::INFINITY,
        };
        // A NaN move (a wall sent to infinity) counts as stale too.
        moved.is_nan() || moved > limit
    })
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
    if c.stale || c.built_at.len() != pos.len() || !c.has_pair_ids() {
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
