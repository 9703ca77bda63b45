//! Neighbour rows (MatDEM's neighbour matrix, stored as CSR rows so a 1:10 size ratio costs
//! no padding) and the per-pair state aligned with them.
//!
//! Every pair appears in both particles' rows, and both copies of its state are updated
//! from exactly mirrored inputs, so they stay identical while each particle sums only its
//! own row: no atomics and no dependence on thread count.

use crate::physics::contact_law::PairState;
use crate::physics::Vec3;
use crate::walls::WallShape;
use serde::{Deserialize, Serialize};
use std::ops::Range;

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Contacts {
    /// Row `i` is `other[row_start[i]..row_start[i + 1]]`, sorted by id.
    pub row_start: Vec<u32>,
    /// Neighbour ids.
    pub other: Vec<u32>,
    /// Pair state, aligned with `other`.
    pub state: Vec<PairState>,
    /// Pair id of each row entry, aligned with `other`: both entries of a pair share it.
    /// Pairs are numbered by (lower id, higher id), so particle `i` owns the pairs
    /// `pair_start[i]..pair_start[i + 1]`, those with its higher-id neighbours, which end
    /// its row. Derived by the rebuild; saved with checkpoints all the same, so a loaded model
    /// keeps the rows it had and continues bit for bit instead of rebuilding early.
    pub pair: Vec<u32>,
    pub pair_start: Vec<u32>,
    /// Walls each particle may touch before the next rebuild, as bits (wall `w` is bit `w`):
    /// those within reach when the mask was built, or whose contact state was still set.
    /// The wall pass tests only these. Derived, and saved for the same reason as `pair`.
    pub wall_near: Vec<u8>,
    /// The walls' shapes when `wall_near` was built; a wall that has moved half a skin
    /// since, or changed shape, makes the mask stale.
    pub walls_at_build: Vec<WallShape>,
    /// Positions when the rows were built; rows are rebuilt once any drift exceeds skin/2.
    pub built_at: Vec<Vec3>,
    /// Extra search distance beyond touching (m).
    pub skin: f64,
    /// Rows must be rebuilt before the next force pass (particles or bonds changed).
    pub stale: bool,
    /// The `rolling_resistance` stage's epsd rolling springs (N·m, the torque on this row's
    /// particle), aligned with `other`; empty unless the plan has epsd. Carried across rebuilds
    /// as `state` is. Saved in a checkpoint's sections (format 7).
    #[serde(skip)]
    pub rolling: Vec<Vec3>,
}

impl Contacts {
    pub fn row(&self, i: usize) -> Range<usize> {
        self.row_start[i] as usize..self.row_start[i + 1] as usize
    }

    /// Position of `j` in row `i`.
    pub fn find(&self, i: usize, j: u32) -> Option<usize> {
        if i + 1 >= self.row_start.len() {
            return None;
        }
        let r = self.row(i);
        self.other[r.clone()].binary_search(&j).ok().map(|k| r.start + k)
    }

    /// Number of pairs (each counted once).
    pub fn pair_count(&self) -> usize {
        self.other.len() / 2
    }

    /// Whether the pair ids match the rows (false until the first rebuild).
    pub fn has_pair_ids(&self) -> bool {
        self.pair.len() == self.other.len() && self.pair_start.len() == self.row_start.len()
    }

    /// Sets the bond flag of pair (i, j) in both rows; false if the pair is not in the rows.
    pub fn set_bond(&mut self, i: usize, j: usize, bonded: bool) -> bool {
        match (self.find(i, j as u32), self.find(j, i as u32)) {
            (Some(a), Some(b)) => {
                self.state[a].bonded = bonded;
                self.state[b].bonded = bonded;
                // A bond made or broken here is whole (or gone): no joint weakening.
                self.state[a].weakened = 0;
                self.state[b].weakened = 0;
                if !bonded {
                    self.state[a].shear = Vec3::zeros();
                    self.state[b].shear = Vec3::zeros();
                }
                true
            }
            _ => false,
        }
    }
}
