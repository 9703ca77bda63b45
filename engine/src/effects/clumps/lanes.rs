//! The `clumps` stage's state: each clump's rigid body, its members and their offsets in its
//! principal frame, and each element's clump.

use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// An element in no clump.
pub const NONE: u32 = u32::MAX;

/// One clump as a rigid body. Velocity and angular momentum live at half steps, as the
/// elements' velocities do.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Body {
    pub mass: f64,
    /// Principal moments of inertia about the centre (kg·m²).
    pub inertia: Vec3,
    /// Centre of mass (m).
    pub pos: Vec3,
    pub vel: Vec3,
    /// Orientation, principal frame → world, as a unit quaternion (w, x, y, z).
    pub orientation: [f64; 4],
    /// Angular momentum about the centre, world frame (kg·m²/s).
    pub ang_mom: Vec3,
}

impl Body {
    pub fn rotation(&self) -> nalgebra::UnitQuaternion<f64> {
        let [w, x, y, z] = self.orientation;
        nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w, x, y, z))
    }

    pub fn set_rotation(&mut self, q: nalgebra::UnitQuaternion<f64>) {
        let c = q.quaternion().coords;
        self.orientation = [c.w, c.x, c.y, c.z];
    }

    /// Kinetic energy of translation and rotation (J), at the velocities' half step.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.mass * self.vel.norm_squared()
            + super::physics::rotational_energy(&self.rotation(), &self.ang_mom, &self.inertia)
    }

    /// Angular velocity, world frame (rad/s).
    pub fn ang_vel(&self) -> Vec3 {
        super::physics::angular_velocity(&self.rotation(), &self.ang_mom, &self.inertia)
    }
}

/// Every clump of a model (empty in a scene without clumps).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Clumps {
    pub bodies: Vec<Body>,
    /// Clump c's members are `members[member_start[c]..member_start[c + 1]]`, ascending.
    pub member_start: Vec<u32>,
    pub members: Vec<u32>,
    /// Each member's centre in its clump's principal frame (m), beside `members`.
    pub offsets: Vec<Vec3>,
    /// Per element: its clump, or [`NONE`]; empty while there are no clumps.
    pub of: Vec<u32>,
}

impl Clumps {
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// Clump c's range in `members` and `offsets`.
    pub fn range(&self, c: usize) -> std::ops::Range<usize> {
        self.member_start[c] as usize..self.member_start[c + 1] as usize
    }

    /// The clump of element i, if any.
    pub fn clump_of(&self, i: usize) -> Option<usize> {
        self.of.get(i).filter(|&&c| c != NONE).map(|&c| c as usize)
    }

    /// Bytes of the state (bodies, members, offsets, one word per element).
    pub fn bytes(&self) -> usize {
        self.bodies.len() * std::mem::size_of::<Body>()
            + self.member_start.len() * 4
            + self.members.len() * (4 + std::mem::size_of::<Vec3>())
            + self.of.len() * 4
    }
}
