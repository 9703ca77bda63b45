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

    /// Renumbers every group after particles were removed.
    pub fn remap(&mut self, map: &[Option<u32>]) {
        for ids in self.map.values_mut() {
            *ids = ids.iter().filter_map(|&i| map[i as usize]).collect();
        }
    }
}
