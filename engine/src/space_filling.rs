//! Points in the order of a space-filling curve (Morton's Z-order over cubic cells), so that
//! particles near in space are near in memory.
//!
//! The steppers read each contact's partner by its id: in a packing whose ids follow the order
//! grains were placed in at random, every partner is a cache miss (the bench lattice shuffled
//! ran 5× slower at 10⁶ particles on the CPU, docs/results/bench_cpu_2026-12-07_order.txt);
//! in Z-order it is almost always a line already loaded. A builder hands out ids in this order.

use crate::physics::Vec3;

/// The permutation that puts `points` in Z-order over cells of `cell` (a particle diameter is
/// about right): `order[k]` is the index of the k-th point. Points of one cell keep their
/// order; the result depends on the points alone (a stable sort), never on threads.
pub fn z_order(points: &[Vec3], cell: f64) -> Vec<usize> {
    if points.is_empty() {
        return Vec::new();
    }
    let lo = points.iter().fold(Vec3::repeat(f64::INFINITY), |a, p| a.inf(p));
    let cell = if cell.is_finite() && cell > 0.0 { cell } else { 1.0 };
    // Cells beyond 2^21 along an axis (a box two million grains across) share the last one.
    let key = |p: &Vec3| {
        let c = |v: f64, lo: f64| (((v - lo) / cell).max(0.0) as u64).min(MAX_CELL);
        spread(c(p.x, lo.x)) | spread(c(p.y, lo.y)) << 1 | spread(c(p.z, lo.z)) << 2
    };
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by_cached_key(|&i| key(&points[i]));
    order
}

/// A builder numbers the grains of a packing of more than this many in Z-order.
pub const SPACE_ORDER_FROM: usize = 10_000;

/// The order a builder gives ids to grains at `places` (of mean diameter `mean_d`): a large
/// packing's in Z-order, so that a grain's partners are near it in memory (a box of 47,241
/// grains stepped 2.3× faster so, one of 5,905 1.13×: docs/results/bench_cpu_2026-12-07_order.txt);
/// one of up to `SPACE_ORDER_FROM` grains, whose lanes the caches hold anyway, as placed, as
/// every packing was numbered before, so that a small scene's run stays as it was.
pub fn id_order(places: &[Vec3], mean_d: f64) -> Vec<usize> {
    if places.len() <= SPACE_ORDER_FROM {
        return (0..places.len()).collect();
    }
    z_order(places, mean_d)
}

const MAX_CELL: u64 = (1 << 21) - 1;

/// The low 21 bits of `v`, each moved to every third bit (bit k to bit 3k).
fn spread(v: u64) -> u64 {
    let mut x = v & MAX_CELL;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_moves_each_bit_to_every_third_place() {
        for v in [0u64, 1, 2, 5, 0x15_5555, MAX_CELL, 123_456] {
            let want = (0..21).filter(|k| v >> k & 1 == 1).fold(0u64, |a, k| a | 1 << (3 * k));
            assert_eq!(spread(v), want, "{v:#x}");
        }
    }

    #[test]
    fn z_order_visits_a_cube_of_cells_octant_by_octant() {
        // 4 × 4 × 4 cells, listed x fastest: the first eight in Z-order are the 2 × 2 × 2
        // corner at the origin, in x, y, z bit order.
        let pts: Vec<Vec3> = (0..64).map(|i| Vec3::new((i % 4) as f64, (i / 4 % 4) as f64, (i / 16) as f64)).collect();
        let order = z_order(&pts, 1.0);
        let first: Vec<usize> = order[..8].to_vec();
        assert_eq!(first, vec![0, 1, 4, 5, 16, 17, 20, 21]);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..64).collect::<Vec<_>>(), "a permutation");
    }

    #[test]
    fn z_order_keeps_neighbours_close_where_random_order_does_not() {
        // A shuffled 16³ lattice: in Z-order a point's face neighbours lie on average within
        // a few dozen places (x-fastest order: 1, 16 and 256); shuffled, ~n/3 away.
        let n = 16usize;
        let mut pts: Vec<Vec3> =
            (0..n * n * n).map(|i| Vec3::new((i % n) as f64, (i / n % n) as f64, (i / (n * n)) as f64)).collect();
        // A fixed shuffle (an LCG's draws).
        let mut state = 3u64;
        for i in (1..pts.len()).rev() {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            pts.swap(i, ((state >> 33) % (i as u64 + 1)) as usize);
        }
        let mean_gap = |order: &[usize]| {
            let mut at = vec![0usize; order.len()];
            for (k, &i) in order.iter().enumerate() {
                at[i] = k;
            }
            let (mut sum, mut count) = (0usize, 0usize);
            for a in 0..pts.len() {
                for b in 0..pts.len() {
                    if (pts[a] - pts[b]).norm() == 1.0 {
                        sum += at[a].abs_diff(at[b]);
                        count += 1;
                    }
                }
            }
            sum as f64 / count as f64
        };
        let identity: Vec<usize> = (0..pts.len()).collect();
        let (shuffled, z) = (mean_gap(&identity), mean_gap(&z_order(&pts, 1.0)));
        assert!(shuffled > 1000.0, "shuffled {shuffled}");
        assert!(z < 100.0, "z-order {z}");
    }

    #[test]
    fn z_order_of_nothing_or_one_point() {
        assert!(z_order(&[], 1.0).is_empty());
        assert_eq!(z_order(&[Vec3::new(-3.0, 2.0, 1.0)], 0.0), vec![0]);
    }
}
