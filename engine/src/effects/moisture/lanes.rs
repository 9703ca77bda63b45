//! The `moisture` stage's per-particle lanes: empty until a scene enables moisture
//! ([`crate::model::Model::fit_moisture`]), then one entry per particle.

use serde::{Deserialize, Serialize};

pub use crate::diffusion::{FIXED, FREE, SEALED};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MoistureLanes {
    /// Gravimetric water content ω (kg of water per kg of element).
    pub water: Vec<f64>,
    /// Moisture diffusivity α_w of the element's material (kg/(m²·s)).
    pub diffusivity: Vec<f64>,
    /// Evaporation transfer coefficient χ (kg/(m²·s)); 0 where the element is not a free
    /// surface.
    pub transfer: Vec<f64>,
    /// The ambient water content ω_a the element dries towards.
    pub ambient: Vec<f64>,
    /// ΣG (with the evaporation's E) at the last field step (kg/s): the stability limit m/ΣG,
    /// and what a script reads.
    pub conductance: Vec<f64>,
    /// [`FREE`], [`FIXED`] or [`SEALED`].
    pub mode: Vec<u8>,
    /// Radius at which the shrinkage table's factor is 1 (m); only with a radius table.
    pub radius0: Vec<f64>,
}

impl MoistureLanes {
    fn f64_lanes_mut(&mut self) -> [&mut Vec<f64>; 6] {
        [
            &mut self.water,
            &mut self.diffusivity,
            &mut self.transfer,
            &mut self.ambient,
            &mut self.conductance,
            &mut self.radius0,
        ]
    }

    /// Whether the lanes are allocated for `n` particles.
    pub fn allocated(&self, n: usize) -> bool {
        self.water.len() == n && n > 0
    }

    /// Extends each allocated lane by one particle (water content `water`, radius `radius`);
    /// the model sets the new element's diffusivity from its material.
    pub fn push(&mut self, n_before: usize, water: f64, radius: f64) {
        if self.water.len() != n_before || self.water.is_empty() {
            return;
        }
        let radius0_on = self.radius0.len() == n_before;
        for lane in self.f64_lanes_mut() {
            if lane.len() == n_before {
                lane.push(0.0);
            }
        }
        self.water[n_before] = water;
        if radius0_on {
            self.radius0[n_before] = radius;
        }
        self.mode.push(FREE);
    }

    /// Keeps the entries of the particles kept.
    pub fn retain(&mut self, keep: &[bool]) {
        fn filter<T: Clone>(v: &mut Vec<T>, keep: &[bool]) {
            if v.len() == keep.len() {
                let mut it = keep.iter();
                v.retain(|_| *it.next().unwrap_or(&false));
            }
        }
        for lane in self.f64_lanes_mut() {
            filter(lane, keep);
        }
        filter(&mut self.mode, keep);
    }

    /// Whether every lane is allocated for `n` particles or absent.
    pub fn consistent(&self, n: usize) -> bool {
        let len = self.water.len();
        (len == 0 || len == n)
            && [&self.diffusivity, &self.transfer, &self.ambient, &self.conductance].iter().all(|l| l.len() == len)
            && self.mode.len() == len
            && (self.radius0.is_empty() || self.radius0.len() == len)
            && self.mode.iter().all(|&k| k == FREE || k == FIXED || k == SEALED)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        let f = [&self.water, &self.diffusivity, &self.transfer, &self.ambient, &self.conductance, &self.radius0];
        f.iter().map(|l| l.len() * 8).sum::<usize>() + self.mode.len()
    }
}
