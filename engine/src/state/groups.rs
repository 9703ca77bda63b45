//! Named groups of particle ids (MatDEM's `d.GROUP`).

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Groups {
    map: BTreeMap<String, Vec<u32>>,
}

impl Groups {
    /// Sets group `name` to `ids` (sorted, deduplicated), replacing an earlier one.
    pub fn set(&mut self, name: &str, mut ids: Vec<u32>) {
        ids.sort_unstable();
        ids.dedup();
        self.map.insert(name.to_string(), ids);
    }

    pub fn get(&self, name: &str) -> Result<&[u32]> {
        self.map.get(name).map(|v| v.as_slice()).ok_or_else(|| {
            let known: Vec<&str> = self.map.keys().map(|s| s.as_str()).collect();
            Error::unknown("group", name, &known)
        })
    }

    pub fn remove(&mut self, name: &str) -> Option<Vec<u32>> {
        self.map.remove(name)
    }

    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.map.keys().map(|s| s.as_str())
    }

    /// Whether every group is as [`Groups::set`] leaves it for `n` particles: ids in
    /// increasing order, each a particle (for checkpoints: hosts index particle lanes with
    /// them). The error names the group and the id.
    pub fn check(&self, n: usize) -> std::result::Result<(), String> {
        for (name, ids) in &self.map {
            if let Some(&bad) = ids.iter().find(|&&i| i as usize >= n) {
                return Err(format!("group `{name}` lists particle {bad}, and the model has {n}"));
            }
            if let Some(w) = ids.windows(2).find(|w| w[0] >= w[1]) {
                return Err(format!("group `{name}` lists particle {} after {} (ids must increase)", w[1], w[0]));
            }
        }
        Ok(())
    }

    /// Renumbers every group after particles were removed.
    pub fn remap(&mut self, map: &[Option<u32>]) {
        for ids in self.map.values_mut() {
            *ids = ids.iter().filter_map(|&i| map[i as usize]).collect();
        }
    }
}
