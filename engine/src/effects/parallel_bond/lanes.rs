//! The `parallel_bond` stage's lanes: the parallel bonds a scene made, as rows of their own
//! (CSR, like the neighbour rows: particle `i`'s bonds are `other[row_start[i]..row_start[i + 1]]`,
//! sorted by id, each pair in both rows) with the bond's state aligned with them. Bonds are
//! made once and only break, so their rows never need the neighbour rows' rebuilds; a broken
//! bond keeps its (zero) entry. Empty, and nothing is allocated, until a scene makes bonds.

use crate::effects::parallel_bond::physics::{status, BondState, ParallelBondParams};
use serde::{Deserialize, Serialize};
use std::ops::Range;

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ParallelBonds {
    /// The bonds' parameters; `None` while the scene has no parallel bonds.
    pub params: Option<ParallelBondParams>,
    /// Row `i` is `other[row_start[i]..row_start[i + 1]]` (empty when no bonds were made).
    pub row_start: Vec<u32>,
    /// Bonded ids, sorted within each row.
    pub other: Vec<u32>,
    /// Each bond's state, the same in both of its rows ([`BondState`]).
    pub state: Vec<BondState>,
}

impl ParallelBonds {
    /// Whether the scene has parallel bonds (the plan then has the stage).
    pub fn enabled(&self) -> bool {
        self.params.is_some()
    }

    pub fn row(&self, i: usize) -> Range<usize> {
        self.row_start[i] as usize..self.row_start[i + 1] as usize
    }

    /// Intact bonds, each counted once.
    pub fn intact(&self) -> usize {
        self.state.iter().filter(|s| s.intact()).count() / 2
    }

    /// Makes the rows from pairs (i < j), all new (no load until they deform), for `n`
    /// particles.
    pub fn make(&mut self, params: ParallelBondParams, pairs: &[(u32, u32)], n: usize) {
        let mut rows: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &(i, j) in pairs {
            rows[i as usize].push(j);
            rows[j as usize].push(i);
        }
        self.params = Some(params);
        self.row_start = Vec::with_capacity(n + 1);
        self.row_start.push(0);
        self.other.clear();
        for mut row in rows {
            row.sort_unstable();
            row.dedup();
            self.other.extend(row);
            self.row_start.push(self.other.len() as u32);
        }
        self.state = vec![BondState { status: status::NEW, ..BondState::default() }; self.other.len()];
    }

    /// Keeps the bonds between survivors of a removal (`map`: old id → new id).
    pub fn retain(&mut self, map: &[Option<u32>]) {
        if self.row_start.is_empty() {
            return;
        }
        let (mut other, mut state, mut row_start) = (Vec::new(), Vec::new(), vec![0u32]);
        for (i, new) in map.iter().enumerate() {
            if new.is_none() {
                continue;
            }
            for e in self.row(i) {
                if let Some(j) = map[self.other[e] as usize] {
                    other.push(j);
                    state.push(self.state[e]);
                }
            }
            row_start.push(other.len() as u32);
        }
        (self.other, self.state, self.row_start) = (other, state, row_start);
    }

    /// Rows for `n` particles: particles added after the bonds were made have none.
    pub fn fit(&mut self, n: usize) {
        if !self.row_start.is_empty() {
            let end = *self.row_start.last().expect("non-empty");
            self.row_start.resize(n + 1, end);
        }
    }

    /// Whether the rows fit `n` particles (for checkpoints).
    pub fn consistent(&self, n: usize) -> bool {
        self.row_start.is_empty() && self.other.is_empty() && self.state.is_empty()
            || self.row_start.len() == n + 1
                && self.row_start.windows(2).all(|w| w[0] <= w[1])
                && self.row_start[n] as usize == self.other.len()
                && self.state.len() == self.other.len()
                && self.other.iter().all(|&j| (j as usize) < n)
    }

    /// Bytes per row entry: the partner's id and the bond's state.
    pub const ENTRY_BYTES: usize = std::mem::size_of::<u32>() + std::mem::size_of::<BondState>();

    /// Heap bytes of the lanes as allocated.
    pub fn bytes(&self) -> usize {
        self.row_start.len() * std::mem::size_of::<u32>() + self.other.len() * Self::ENTRY_BYTES
    }
}
