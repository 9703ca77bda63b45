//! The conversions between the host's CSR rows and the device's fixed-width slots, rank by
//! rank (the layout `row_slot` in common.wgsl reads): at upload, at download and after a build
//! on the host.

use crate::physics::contact_law::PairState;
use crate::physics::Vec3;
use crate::state::contacts::Contacts;

/// Rows in fixed-width slots, row by row: entry k of particle i at `i * cap + k`, `row_len[i]`
/// in use. The device keeps each slab's slots rank by rank instead ([`by_rank`]).
pub struct Slots {
    pub cap: usize,
    pub row_len: Vec<u32>,
    pub other: Vec<u32>,
    pub state: Vec<[f32; 4]>,
    /// The pairs' dashpot forces of the last step; empty when the plan has no dashpot.
    pub dashpot: Vec<f32>,
    /// The pairs' epsd rolling springs; empty unless the plan has epsd.
    pub rolling: Vec<[f32; 4]>,
}

/// The host's rows (`n` of them, each at most `cap` long) in slots; states in f32, dashpot
/// forces only when `dashpot`, epsd rolling springs only when `rolling` (zero where the host's
/// rows have none).
pub fn to_slots(c: &Contacts, n: usize, cap: usize, dashpot: bool, rolling: bool) -> Slots {
    let mut s = Slots {
        cap,
        row_len: vec![0; n],
        other: vec![0; n * cap],
        state: vec![[0.0; 4]; n * cap],
        dashpot: if dashpot { vec![0.0; n * cap] } else { Vec::new() },
        rolling: if rolling { vec![[0.0; 4]; n * cap] } else { Vec::new() },
    };
    let springs = rolling && c.rolling.len() == c.other.len();
    for i in 0..n.min(c.row_start.len().saturating_sub(1)) {
        let row = c.row(i);
        s.row_len[i] = row.len() as u32;
        for (k, e) in row.enumerate() {
            let st = &c.state[e];
            s.other[i * cap + k] = c.other[e];
            // w: 0 unbonded, else the bond's share of its strength (1 unless a joint weakened it).
            let w = if st.bonded { st.strength() as f32 } else { 0.0 };
            s.state[i * cap + k] = [st.shear.x as f32, st.shear.y as f32, st.shear.z as f32, w];
            if dashpot {
                s.dashpot[i * cap + k] = st.dashpot;
            }
            if springs {
                let r = &c.rolling[e];
                s.rolling[i * cap + k] = [r.x as f32, r.y as f32, r.z as f32, 0.0];
            }
        }
    }
    s
}

/// A slab's slots as the host holds them, row by row (`count` rows of `cap`), laid rank by
/// rank as the device keeps them: entry k of row r at k·count + r (`row_slot` in
/// common.wgsl), so that a warp's invocations, which hold neighbouring rows, read neighbouring
/// words at each entry.
pub fn by_rank<T: Copy>(rows: &[T], cap: usize) -> Vec<T> {
    let count = rows.len() / cap.max(1);
    (0..rows.len()).map(|slot| rows[(slot % count) * cap + slot / count]).collect()
}

/// A slab's slots as the device keeps them (rank by rank), back row by row: [`by_rank`]
/// undone.
pub fn by_row<T: Copy>(ranks: &[T], cap: usize) -> Vec<T> {
    let count = ranks.len() / cap.max(1);
    (0..ranks.len()).map(|slot| ranks[(slot % cap) * count + slot / cap]).collect()
}

/// Replaces the rows of `c` by the slots' (built at `built_at`), with the pair ids the host's
/// rebuild would give them: pairs numbered by (lower id, higher id). The wall mask is left
/// to the caller, which knows the walls.
pub fn into_contacts(s: &Slots, built_at: Vec<Vec3>, c: &mut Contacts) {
    let n = s.row_len.len();
    let mut row_start = Vec::with_capacity(n + 1);
    row_start.push(0u32);
    let mut other = Vec::new();
    let mut state = Vec::new();
    let mut rolling = Vec::new();
    for i in 0..n {
        let slots = i * s.cap..i * s.cap + s.row_len[i] as usize;
        if !s.rolling.is_empty() {
            rolling.extend(
                s.rolling[slots.clone()].iter().map(|g| Vec3::new(f64::from(g[0]), f64::from(g[1]), f64::from(g[2]))),
            );
        }
        other.extend_from_slice(&s.other[slots.clone()]);
        state.extend(slots.map(|e| {
            let g = s.state[e];
            PairState {
                shear: Vec3::new(f64::from(g[0]), f64::from(g[1]), f64::from(g[2])),
                bonded: g[3] != 0.0,
                dashpot: s.dashpot.get(e).copied().unwrap_or(0.0),
                // w holds 1 − weakened/65535 in f32 (24 bits): rounding recovers it exactly.
                weakened: if g[3] != 0.0 { PairState::weakened_for(f64::from(g[3])) } else { 0 },
            }
        }));
        row_start.push(other.len() as u32);
    }
    let mut pair = vec![0u32; other.len()];
    let mut pair_start = vec![0u32; n + 1];
    let mut next = 0u32;
    for i in 0..n {
        pair_start[i] = next;
        for e in row_start[i] as usize..row_start[i + 1] as usize {
            let j = other[e] as usize;
            if j > i {
                pair[e] = next;
                // Rows are sorted and mirrored: the twin entry is i in row j.
                let r = row_start[j] as usize..row_start[j + 1] as usize;
                if let Ok(k) = other[r.clone()].binary_search(&(i as u32)) {
                    pair[r.start + k] = next;
                }
                next += 1;
            }
        }
    }
    pair_start[n] = next;
    *c = Contacts {
        row_start,
        other,
        state,
        pair,
        pair_start,
        wall_near: Vec::new(),
        walls_at_build: Vec::new(),
        built_at,
        skin: c.skin,
        stale: false,
        rolling,
    };
}

#[cfg(test)]
mod tests {
    #[test]
    fn slots_go_rank_by_rank_on_the_device_and_back() {
        // Three rows of two: (a0 a1) (b0 b1) (c0 c1) → a0 b0 c0 a1 b1 c1.
        let rows = [10, 11, 20, 21, 30, 31];
        assert_eq!(by_rank(&rows, 2), vec![10, 20, 30, 11, 21, 31]);
        assert_eq!(by_row(&by_rank(&rows, 2), 2), rows.to_vec());
        assert!(by_rank::<u32>(&[], 4).is_empty());
    }

    use super::*;

    fn contacts(rows: &[&[u32]]) -> Contacts {
        let mut c = Contacts::default();
        c.row_start.push(0);
        for (i, r) in rows.iter().enumerate() {
            for &j in *r {
                c.other.push(j);
                let bonded = (i as u32).min(j) == 0;
                // Dashpot forces exact in f32, so the round trip is exact.
                let dashpot = 0.25 * j as f32;
                // Some bonds weakened (a joint), so their share rides along in w.
                let weakened = if bonded && j % 2 == 1 { PairState::weakened_for(0.2) } else { 0 };
                c.state.push(PairState { shear: Vec3::new(i as f64, j as f64, 0.5), bonded, dashpot, weakened });
            }
            c.row_start.push(c.other.len() as u32);
        }
        c
    }

    #[test]
    fn rows_and_dashpot_forces_go_to_slots_and_back_with_the_host_pair_ids() {
        let mut c = contacts(&[&[1, 3], &[0, 2, 3], &[1], &[0, 1]]);
        c.skin = 1e-4;
        assert!(to_slots(&c, 4, 5, false, false).dashpot.is_empty(), "no dashpot lane without a dashpot");
        let s = to_slots(&c, 4, 5, true, false);
        assert_eq!(s.row_len, [2, 3, 1, 2]);
        assert_eq!(&s.other[5..8], [0, 2, 3]);
        assert_eq!(s.state[5], [1.0, 0.0, 0.5, 1.0]);
        assert_eq!(&s.dashpot[5..8], [0.0, 0.5, 0.75]);
        let before = c.clone();
        into_contacts(&s, vec![Vec3::zeros(); 4], &mut c);
        assert_eq!((c.row_start.clone(), c.other.clone()), (before.row_start, before.other));
        assert_eq!(c.state, before.state);
        // Pairs by (lower, higher): (0,1) (0,3) (1,2) (1,3); each pair's two entries share its id.
        assert_eq!(c.pair, [0, 1, 0, 2, 3, 2, 1, 3]);
        assert_eq!(c.pair_start, [0, 2, 4, 4, 4]);
        assert!(c.has_pair_ids() && c.skin == 1e-4 && !c.stale);
    }
}
