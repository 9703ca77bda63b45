//! Per-particle state as a struct of arrays: one lane per quantity, indexed by particle id
//! (0-based), so a stage touches only the lanes it needs and a GPU upload is a lane copy.

use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// Blocked translational degrees of freedom, as bits.
pub mod dof {
    pub const X: u8 = 1;
    pub const Y: u8 = 2;
    pub const Z: u8 = 4;
    pub const ALL: u8 = X | Y | Z;
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Particles {
    /// Centre (m).
    pub pos: Vec<Vec3>,
    /// Radius (m).
    pub radius: Vec<f64>,
    /// Velocity (m/s), at the half step (leapfrog).
    pub vel: Vec<Vec3>,
    /// Mass (kg), from the material's density.
    pub mass: Vec<f64>,
    /// Force of the current step (N).
    pub force: Vec<Vec3>,
    /// Index into the model's materials.
    pub material: Vec<u32>,
    /// Blocked degrees of freedom (bits of [`dof`]); a blocked component keeps its velocity.
    pub fixed: Vec<u8>,
    /// Position when the model was built, for displacement fields.
    pub origin: Vec<Vec3>,
    /// Angular state, present only when rotation is simulated.
    pub rotation: Option<Rotation>,
    /// Heat released per particle since the start (J), by cause.
    pub heat: HeatLedger,
}

/// Angular velocity and torque lanes.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Rotation {
    pub ang_vel: Vec<Vec3>,
    pub torque: Vec<Vec3>,
}

/// Per-particle energy ledger: heat released by each cause and work done by walls (J).
/// Each particle books its half of every pair's heat, so no two threads write one entry.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct HeatLedger {
    pub damping: Vec<f64>,
    pub contact_damping: Vec<f64>,
    pub friction: Vec<f64>,
    pub breakage: Vec<f64>,
    pub wall_work: Vec<f64>,
}

impl Particles {
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Appends a particle and returns its id.
    pub fn push(&mut self, pos: Vec3, radius: f64, mass: f64, material: u32) -> usize {
        self.pos.push(pos);
        self.radius.push(radius);
        self.vel.push(Vec3::zeros());
        self.mass.push(mass);
        self.force.push(Vec3::zeros());
        self.material.push(material);
        self.fixed.push(0);
        self.origin.push(pos);
        if let Some(rot) = &mut self.rotation {
            rot.ang_vel.push(Vec3::zeros());
            rot.torque.push(Vec3::zeros());
        }
        for lane in self.heat.lanes_mut() {
            lane.push(0.0);
        }
        self.len() - 1
    }

    /// Keeps only the particles for which `keep` is true; returns the old → new id map.
    pub fn retain(&mut self, keep: &[bool]) -> Vec<Option<u32>> {
        let mut map = vec![None; self.len()];
        let mut next = 0u32;
        for (i, k) in keep.iter().enumerate() {
            if *k {
                map[i] = Some(next);
                next += 1;
            }
        }
        fn filter<T: Clone>(v: &mut Vec<T>, keep: &[bool]) {
            let mut it = keep.iter();
            v.retain(|_| *it.next().unwrap_or(&false));
        }
        filter(&mut self.pos, keep);
        filter(&mut self.radius, keep);
        filter(&mut self.vel, keep);
        filter(&mut self.mass, keep);
        filter(&mut self.force, keep);
        filter(&mut self.material, keep);
        filter(&mut self.fixed, keep);
        filter(&mut self.origin, keep);
        if let Some(rot) = &mut self.rotation {
            filter(&mut rot.ang_vel, keep);
            filter(&mut rot.torque, keep);
        }
        for lane in self.heat.lanes_mut() {
            filter(lane, keep);
        }
        map
    }

    /// Allocates the angular lanes (rotation switched on).
    pub fn enable_rotation(&mut self) {
        if self.rotation.is_none() {
            self.rotation =
                Some(Rotation { ang_vel: vec![Vec3::zeros(); self.len()], torque: vec![Vec3::zeros(); self.len()] });
        }
    }

    /// Moment of inertia of a solid sphere, 2/5·m·r².
    pub fn inertia(&self, i: usize) -> f64 {
        0.4 * self.mass[i] * self.radius[i] * self.radius[i]
    }
}

impl HeatLedger {
    pub fn lanes_mut(&mut self) -> [&mut Vec<f64>; 5] {
        [&mut self.damping, &mut self.contact_damping, &mut self.friction, &mut self.breakage, &mut self.wall_work]
    }
}
