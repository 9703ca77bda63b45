//! Neighbour rows (the `neighbours` stage), the engine's and not one backend's: the CPU backend
//! steps on them, the GPU backend uploads them (and rebuilds them on the device with the same
//! content and order, falling back to [`rebuild`] when a row outgrows its slots), and the
//! model, the observers and the bench build them before anything reads a contact.
//!
//! Rows come from a cell list with a skin (Verlet lists, `cell_list.rs`), rebuilt only when
//! some particle has drifted more than half the skin since the last build ([`is_stale`]).
//! Each pair is found once, by its larger particle searching a reach of 2·r + skin, so a
//! wide gradation costs the small particles no more than a mono-size packing; the pairs
//! are then mirrored into both rows. Pair state is carried across rebuilds, and bonded
//! pairs stay in the rows however far apart they drift.
//!
//! Walls get the same treatment: each particle carries a mask of the walls it may touch
//! before the next rebuild, rebuilt alone when only a wall has moved.

mod cell_list;
mod drift;

pub use drift::{is_stale, steps_until_rebuild, steps_until_rebuild_sheared, walls_stale};

use crate::effects::clumps::lanes::NONE;
use crate::model::Model;
use crate::physics::contact_law::PairState;
use crate::physics::Vec3;
use crate::state::contacts::Contacts;
use crate::state::particles::dof;
use cell_list::find_pairs;
use rayon::prelude::*;

/// Rebuilds the model's rows for the current positions.
pub fn rebuild(m: &mut Model) {
    let p = &m.particles;
    let n = p.len();
    if m.contacts.skin <= 0.0 {
        m.contacts.skin = m.settings.skin_ratio * m.mean_radius();
    }
    let skin = m.contacts.skin;
    let mut pairs = if n == 0 {
        Vec::new()
    } else {
        find_pairs(&p.pos, &p.radius, &p.fixed, skin, m.effects.periodic.cell.as_ref())
    };
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
    // Members of one clump never touch: their clump is rigid (bonds between them go too).
    if !m.clumps.is_empty() {
        let of = |i: u32| m.clumps.of.get(i as usize).copied().unwrap_or(NONE);
        pairs.retain(|&(i, j)| of(i) == NONE || of(i) != of(j));
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
    // The epsd rolling springs (only while a plan has them), carried as the pair states are.
    let rolling: Vec<Vec3> = if old.rolling.len() == old.other.len() && !old.rolling.is_empty() {
        (0..n)
            .into_par_iter()
            .flat_map_iter(|i| {
                let r = row_start[i] as usize..row_start[i + 1] as usize;
                other[r].iter().map(move |&j| old.find(i, j).map_or(Vec3::zeros(), |e| old.rolling[e]))
            })
            .collect()
    } else {
        Vec::new()
    };
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
        rolling,
    };
    if let Some(s) = m.effects.periodic.cell.as_mut().and_then(|c| c.shear.as_mut()) {
        s.offset_at_build = s.offset;
    }
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
        // A killed element touches no wall (its states were cleared when it was killed).
        if p.fixed[i] & dof::KILLED != 0 {
            return bits;
        }
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
