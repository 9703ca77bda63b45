//! The `applied_loads` stage's per-particle lanes: an external force (N) and torque (N·m) on each
//! element, constant until a script changes them, and the offset that keeps their work in the
//! energy account. Empty until a scene applies a load ([`crate::model::Model::apply_force`]),
//! then one entry per particle; released again when every load is zero.
//!
//! **The work account.** Between two changes an element's loads are constant, so the work they do
//! is F·Δx + T·Δθ (θ the element's accumulated rotation, `Rotation::angle`): a potential, as
//! gravity's −m·g·x is. Each element's work to date is therefore
//!
//! ```text
//! W_i = F_i·x_i + T_i·θ_i + c_i,
//! ```
//!
//! and a change of its loads from (F, T) to (F′, T′) where it stands moves the offset by
//! (F − F′)·x + (T − T′)·θ, so that W_i carries on unbroken. The account needs no pass of its own
//! and nothing on the device: it is read from the positions and angles whenever the energies are.
//! The leapfrog conserves mechanical energy minus this work as it does mechanical energy with
//! gravity (`status::Energies::applied_work`).

use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AppliedLoads {
    /// External force on each element (N).
    pub force: Vec<Vec3>,
    /// External torque on each element (N·m); it turns rotation on.
    pub torque: Vec<Vec3>,
    /// c_i of the work account (J): W_i = F_i·x_i + T_i·θ_i + c_i.
    pub offset: Vec<f64>,
    /// Work of loads no longer in the lanes (J): those of removed elements are dropped with them
    /// (as their heat is), those released when every load became zero are kept here.
    pub booked: f64,
}

impl AppliedLoads {
    /// Whether the lanes are allocated for `n` particles.
    pub fn allocated(&self, n: usize) -> bool {
        n > 0 && self.force.len() == n
    }

    /// Whether every lane holds `n` entries, or none (and a loaded checkpoint's are finite).
    pub fn consistent(&self, n: usize) -> bool {
        let lens = [self.force.len(), self.torque.len(), self.offset.len()];
        let sized = lens.iter().all(|&l| l == 0) || lens.iter().all(|&l| l == n);
        let finite = self.force.iter().chain(&self.torque).all(|v| v.iter().all(|c| c.is_finite()))
            && self.offset.iter().all(|c| c.is_finite())
            && self.booked.is_finite();
        sized && finite
    }

    /// Allocates zero loads for `n` particles (a no-op once allocated).
    pub fn fit(&mut self, n: usize) {
        if !self.allocated(n) {
            self.force = vec![Vec3::zeros(); n];
            self.torque = vec![Vec3::zeros(); n];
            self.offset = vec![0.0; n];
        }
    }

    /// Extends allocated lanes by one (unloaded) particle.
    pub fn push(&mut self, n_before: usize) {
        if self.allocated(n_before) {
            self.force.push(Vec3::zeros());
            self.torque.push(Vec3::zeros());
            self.offset.push(0.0);
        }
    }

    /// Keeps the entries of the particles `keep` keeps.
    pub fn retain(&mut self, keep: &[bool]) {
        if self.allocated(keep.len()) {
            let mut k = keep.iter();
            self.force.retain(|_| *k.next().unwrap_or(&false));
            let mut k = keep.iter();
            self.torque.retain(|_| *k.next().unwrap_or(&false));
            let mut k = keep.iter();
            self.offset.retain(|_| *k.next().unwrap_or(&false));
        }
    }

    /// Elements with a load (force or torque) other than zero.
    pub fn loaded(&self) -> usize {
        (0..self.force.len()).filter(|&i| self.is_loaded(i)).count()
    }

    /// Whether element `i` carries a load.
    pub fn is_loaded(&self, i: usize) -> bool {
        self.force[i] != Vec3::zeros() || self.torque[i] != Vec3::zeros()
    }

    /// Whether any element carries a torque.
    pub fn has_torque(&self) -> bool {
        self.torque.iter().any(|t| *t != Vec3::zeros())
    }

    /// Element `i`'s work to date (J), at position `x` and accumulated rotation `angle`.
    #[inline]
    pub fn work_at(&self, i: usize, x: &Vec3, angle: &Vec3) -> f64 {
        self.force[i].dot(x) + self.torque[i].dot(angle) + self.offset[i]
    }

    /// Sets element `i`'s loads where it stands (position `x`, rotation `angle`), moving its
    /// offset so that its work carries on unbroken. `None` keeps that load as it is.
    pub fn set(&mut self, i: usize, x: &Vec3, angle: &Vec3, force: Option<Vec3>, torque: Option<Vec3>) {
        if let Some(f) = force {
            self.offset[i] += (self.force[i] - f).dot(x);
            self.force[i] = f;
        }
        if let Some(t) = torque {
            self.offset[i] += (self.torque[i] - t).dot(angle);
            self.torque[i] = t;
        }
    }

    /// Heap bytes held.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        (self.force.len() + self.torque.len()) * size_of::<Vec3>() + self.offset.len() * size_of::<f64>()
    }

    /// Frees the lanes, keeping their work to date (`work` = Σ W_i at the current state) in
    /// [`booked`](Self::booked).
    pub fn release(&mut self, work: f64) {
        self.booked = work;
        self.force = Vec::new();
        self.torque = Vec::new();
        self.offset = Vec::new();
    }
}
