//! Per-particle state as a struct of arrays: one lane per quantity, indexed by particle id
//! (0-based), so a stage touches only the lanes it needs and a GPU upload is a lane copy.

use crate::effects::applied_loads::lanes::AppliedLoads;
use crate::effects::conduction::lanes::ThermalLanes;
use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// Blocked translational degrees of freedom, as bits.
pub mod dof {
    pub const X: u8 = 1;
    pub const Y: u8 = 2;
    pub const Z: u8 = 4;
    /// Every translation (a particle fixed in place).
    pub const ALL: u8 = X | Y | Z;
    /// Rotation about x, y, z (the angular velocity's component kept as it is).
    pub const RX: u8 = 8;
    pub const RY: u8 = 16;
    pub const RZ: u8 = 32;
    pub const ROTATION: u8 = RX | RY | RZ;
    /// Killed (MatDEM `killElement`, `Model::kill`): every other bit set too, out of the
    /// neighbour rows and the wall contacts, left out of statistics and pictures. Bit 6, so the
    /// GPU's `kind` lane carries it at bit 30 beside the other fixities.
    pub const KILLED: u8 = 64;
    /// A clump's member (effects/clumps/): moved by its clump's body, not integrated on its
    /// own. Bit 7, the GPU's `kind` bit 31.
    pub const CLUMPED: u8 = 128;
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
    /// Heat released per particle since the start (J), by cause: only the lanes of the causes
    /// a plan with the ledger can produce are allocated ([`HeatLedger::fit`]).
    pub heat: HeatLedger,
    /// The `conduction` stage's lanes: temperature, capacity, … (empty while heat is off).
    /// Saved after the model in a checkpoint (format 4), so that older checkpoints still read.
    #[serde(skip)]
    pub thermal: ThermalLanes,
    /// The `applied_loads` stage's lanes: external forces and torques and their work account
    /// (empty until a scene applies a load). Saved in a checkpoint's sections.
    #[serde(skip)]
    pub applied: AppliedLoads,
}

/// Angular velocity, torque and rotation angle lanes.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Rotation {
    pub ang_vel: Vec<Vec3>,
    pub torque: Vec<Vec3>,
    /// The accumulated rotation θ = ∫ω dt (rad), advanced with the angular velocity (θ += ω·dt
    /// with the half-step ω, as positions are). A vector, not an orientation: about a fixed axis
    /// it is the angle turned; about changing axes it is the integral of ω, which is what an
    /// applied torque's work T·Δθ needs (docs/physics.md). Saved in a checkpoint's sections,
    /// so that older checkpoints still read (their elements start at zero).
    #[serde(skip)]
    pub angle: Vec<Vec3>,
}

/// Per-particle energy ledger: heat released by each cause and work done by walls (J).
/// Each particle books its half of every pair's heat, so no two threads write one entry.
/// The lane set of the `heat` stage: a lane is allocated (one entry per particle) only once a
/// plan that can produce its cause runs, and is empty otherwise; an empty lane sums to 0.
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
            rot.angle.push(Vec3::zeros());
        }
        let n = self.len() - 1;
        self.applied.push(n);
        // Only allocated lanes grow; a plan allocates the others when it needs them.
        for lane in self.heat.lanes_mut() {
            if n > 0 && lane.len() == n {
                lane.push(0.0);
            }
        }
        // The reference temperature is the model's: it sets it after the push.
        self.thermal.push(n, 0.0, radius);
        n
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
            filter(&mut rot.angle, keep);
        }
        self.applied.retain(keep);
        for lane in self.heat.lanes_mut() {
            if lane.len() == keep.len() {
                filter(lane, keep);
            }
        }
        self.thermal.retain(keep);
        map
    }

    /// Allocates the angular lanes (rotation switched on).
    pub fn enable_rotation(&mut self) {
        if self.rotation.is_none() {
            let zeros = vec![Vec3::zeros(); self.len()];
            self.rotation = Some(Rotation { ang_vel: zeros.clone(), torque: zeros.clone(), angle: zeros });
        }
    }

    /// Heap bytes of the lanes as allocated (core, rotation, heat ledger, thermal, applied
    /// loads; the effects' states count theirs, `Model::lane_bytes`).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        let core = self.pos.len() * (4 * size_of::<Vec3>() + 2 * size_of::<f64>() + size_of::<u32>() + 1);
        let rotation = self
            .rotation
            .as_ref()
            .map_or(0, |r| (r.ang_vel.len() + r.torque.len() + r.angle.len()) * size_of::<Vec3>());
        core + rotation + self.heat.bytes() + self.thermal.bytes() + self.applied.bytes()
    }

    /// Element `i`'s accumulated rotation (zero without the rotation lanes).
    #[inline]
    pub fn angle(&self, i: usize) -> Vec3 {
        self.rotation.as_ref().and_then(|r| r.angle.get(i).copied()).unwrap_or_else(Vec3::zeros)
    }

    /// The work the applied loads have done on the model (J): Σ W_i over the elements
    /// (`effects::applied_loads::lanes`), plus what released lanes booked.
    pub fn applied_work(&self) -> f64 {
        let a = &self.applied;
        let lanes: f64 = if a.allocated(self.len()) {
            (0..self.len()).map(|i| a.work_at(i, &self.pos[i], &self.angle(i))).sum()
        } else {
            0.0
        };
        a.booked + lanes
    }

    /// Moment of inertia of a solid sphere, 2/5·m·r².
    pub fn inertia(&self, i: usize) -> f64 {
        0.4 * self.mass[i] * self.radius[i] * self.radius[i]
    }
}

/// The causes of heat a plan can produce, in the order of [`HeatLedger::lanes_mut`]: the
/// ledger lanes it allocates and books. All off when the scene keeps no ledger.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HeatCauses {
    /// Global viscous or local damping.
    pub damping: bool,
    /// Contact dashpots (restitution < 1).
    pub contact_damping: bool,
    /// Shear springs, which release their energy as they slide or open.
    pub friction: bool,
    /// Bonds, whose stored energy a break releases.
    pub breakage: bool,
    /// Walls that move, and so do work.
    pub wall_work: bool,
}

impl HeatCauses {
    /// The lanes' names, in ledger order.
    pub const NAMES: [&'static str; 5] = ["damping", "contact_damping", "friction", "breakage", "wall_work"];

    /// Each cause on or off, in ledger order.
    pub fn flags(&self) -> [bool; 5] {
        [self.damping, self.contact_damping, self.friction, self.breakage, self.wall_work]
    }

    /// Lanes a particle carries.
    pub fn lanes(&self) -> usize {
        self.flags().iter().filter(|on| **on).count()
    }

    /// The names of the lanes that are on.
    pub fn names(&self) -> Vec<&'static str> {
        Self::NAMES.into_iter().zip(self.flags()).filter(|(_, on)| *on).map(|(n, _)| n).collect()
    }
}

impl HeatLedger {
    pub fn lanes_mut(&mut self) -> [&mut Vec<f64>; 5] {
        [&mut self.damping, &mut self.contact_damping, &mut self.friction, &mut self.breakage, &mut self.wall_work]
    }

    pub fn lanes(&self) -> [&Vec<f64>; 5] {
        [&self.damping, &self.contact_damping, &self.friction, &self.breakage, &self.wall_work]
    }

    /// Allocates the lanes of `causes` for `n` particles (zero heat). Lanes outside `causes`
    /// are left as they are: one that was booked by an earlier plan keeps its heat.
    pub fn fit(&mut self, causes: &HeatCauses, n: usize) {
        for (lane, on) in self.lanes_mut().into_iter().zip(causes.flags()) {
            if on && lane.len() != n {
                debug_assert!(lane.is_empty(), "a heat lane of {} entries for {n} particles", lane.len());
                lane.resize(n, 0.0);
            }
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.lanes().iter().map(|l| l.len() * std::mem::size_of::<f64>()).sum()
    }
}
