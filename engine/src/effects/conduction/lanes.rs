//! The `conduction` stage's per-particle lanes: empty until a scene enables heat
//! ([`crate::model::Model::fit_thermal`]), then one entry per particle.

use serde::{Deserialize, Serialize};

/// [`ThermalLanes::mode`]: free (exchanges heat with its neighbours), fixed (held at its
/// temperature), insulated (exchanges no heat with any neighbour): the diffusion core's modes.
pub use crate::diffusion::{FIXED, FREE, SEALED as INSULATED};

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ThermalLanes {
    /// Temperature T (the scene's unit, K by convention).
    pub temperature: Vec<f64>,
    /// Heat capacity C = m·c (J/K).
    pub capacity: Vec<f64>,
    /// Conductivity k of the element's solid (W/(m·K)).
    pub conductivity: Vec<f64>,
    /// Heat source (W).
    pub source: Vec<f64>,
    /// ΣH over the element's conducting pairs at the last field step (W/K): the stability
    /// limit C/ΣH, and what a script reads as the element's conductance.
    pub conductance: Vec<f64>,
    /// [`FREE`], [`FIXED`] or [`INSULATED`].
    pub mode: Vec<u8>,
    /// Linear expansion coefficient α (1/K); empty when no element expands.
    pub expansion: Vec<f64>,
    /// Radius at the reference temperature (m); allocated with `expansion`.
    pub radius0: Vec<f64>,
    /// Ledger heat already fed into the temperature (J); only when dissipation is fed.
    pub fed: Vec<f64>,
}

impl ThermalLanes {
    fn f64_lanes_mut(&mut self) -> [&mut Vec<f64>; 8] {
        [
            &mut self.temperature,
            &mut self.capacity,
            &mut self.conductivity,
            &mut self.source,
            &mut self.conductance,
            &mut self.expansion,
            &mut self.radius0,
            &mut self.fed,
        ]
    }

    /// Extends each allocated lane by one particle (`radius` its radius0); the model sets the
    /// new element's properties from its material.
    pub fn push(&mut self, n_before: usize, temperature: f64, radius: f64) {
        if self.temperature.len() != n_before || n_before == 0 && self.temperature.is_empty() {
            return;
        }
        let radius0_on = self.radius0.len() == n_before;
        for lane in self.f64_lanes_mut() {
            if lane.len() == n_before {
                lane.push(0.0);
            }
        }
        self.temperature[n_before] = temperature;
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

    /// Whether every lane is allocated for `n` particles or absent (temperature, capacity,
    /// conductivity, source, conductance and mode together).
    pub fn consistent(&self, n: usize) -> bool {
        let base = [&self.temperature, &self.capacity, &self.conductivity, &self.source, &self.conductance];
        let len = self.temperature.len();
        (len == 0 || len == n)
            && base.iter().all(|l| l.len() == len)
            && self.mode.len() == len
            && [&self.expansion, &self.radius0, &self.fed].iter().all(|l| l.is_empty() || l.len() == n)
            && self.expansion.len() == self.radius0.len()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        let f = [
            &self.temperature,
            &self.capacity,
            &self.conductivity,
            &self.source,
            &self.conductance,
            &self.expansion,
            &self.radius0,
            &self.fed,
        ];
        f.iter().map(|l| l.len() * 8).sum::<usize>() + self.mode.len()
    }
}
