//! Safe, deterministic data parallelism over particle blocks.
//!
//! Particle lanes and row lanes are split recursively at fixed block boundaries (rayon's
//! `join`), so each task owns disjoint slices and the reduction tree depends only on the
//! particle count, never on the number of threads: sums come out bitwise identical with
//! 1 or 64 threads.

use std::ops::Range;

/// Particles per leaf task.
pub const BLOCK: usize = 256;

/// Lanes that can be split at a position (slices and tuples of slices).
pub trait Split: Sized + Send {
    fn split_at(self, mid: usize) -> (Self, Self);
}

impl<T: Send> Split for &mut [T] {
    fn split_at(self, mid: usize) -> (Self, Self) {
        self.split_at_mut(mid)
    }
}

/// A particle lane with `stride` entries per particle (e.g. one contact state per wall).
pub struct Strided<'a, T> {
    pub items: &'a mut [T],
    pub stride: usize,
}

impl<T: Send> Split for Strided<'_, T> {
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (l, r) = self.items.split_at_mut(mid * self.stride);
        (Strided { items: l, stride: self.stride }, Strided { items: r, stride: self.stride })
    }
}

impl Split for () {
    fn split_at(self, _: usize) -> (Self, Self) {
        ((), ())
    }
}

impl<A: Split> Split for Option<A> {
    fn split_at(self, mid: usize) -> (Self, Self) {
        match self {
            Some(a) => {
                let (l, r) = a.split_at(mid);
                (Some(l), Some(r))
            }
            None => (None, None),
        }
    }
}

macro_rules! split_tuple {
    ($($t:ident $i:tt),+) => {
        impl<$($t: Split),+> Split for ($($t,)+) {
            fn split_at(self, mid: usize) -> (Self, Self) {
                $(let $t = self.$i.split_at(mid);)+
                (($($t.0,)+), ($($t.1,)+))
            }
        }
    };
}
#[allow(non_snake_case)]
mod tuples {
    use super::Split;
    split_tuple!(A 0, B 1);
    split_tuple!(A 0, B 1, C 2);
    split_tuple!(A 0, B 1, C 2, D 3);
    split_tuple!(A 0, B 1, C 2, D 3, E 4);
    split_tuple!(A 0, B 1, C 2, D 3, E 4, F 5);
}

/// A per-block result combined in a fixed tree order.
pub trait Reduce: Send + Default {
    fn combine(self, other: Self) -> Self;
}

impl Reduce for () {
    fn combine(self, _: Self) -> Self {}
}

/// How particles map to entries of the row lanes.
#[derive(Clone, Copy)]
pub enum Rows<'a> {
    /// No row lanes.
    None,
    /// CSR rows: particle `i` owns `row_start[i]..row_start[i + 1]`.
    Csr(&'a [u32]),
    /// A fixed number of entries per particle.
    Stride(usize),
}

/// Runs `leaf(range, particle_lanes, row_lanes)` over blocks of particles in parallel.
pub fn for_blocks<P, S, R, F>(particles: Range<usize>, rows: Rows<'_>, p: P, s: S, leaf: &F) -> R
where
    P: Split,
    S: Split,
    R: Reduce,
    F: Fn(Range<usize>, P, S) -> R + Sync,
{
    let n = particles.len();
    if n <= BLOCK {
        return leaf(particles, p, s);
    }
    // Split at a multiple of BLOCK so the tree is the same for every thread count.
    let mid_count = n.div_ceil(BLOCK) / 2 * BLOCK;
    let mid = particles.start + mid_count;
    let (pl, pr) = p.split_at(mid_count);
    let (sl, sr) = match rows {
        Rows::Csr(rs) => s.split_at((rs[mid] - rs[particles.start]) as usize),
        Rows::Stride(k) => s.split_at(mid_count * k),
        Rows::None => s.split_at(0),
    };
    let (a, b) = rayon::join(
        || for_blocks(particles.start..mid, rows, pl, sl, leaf),
        || for_blocks(mid..particles.end, rows, pr, sr, leaf),
    );
    a.combine(b)
}
