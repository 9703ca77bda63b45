//! Walls as analytic primitives: planes (box sides, platens) and the inside of a vertical
//! cylinder (the oedometer ring). A wall moves at a prescribed velocity or is servo-controlled
//! to a target stress; the force particles exert on it is recorded every step.

use crate::error::{check_positive, Error, Result};
use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// The most walls a scene may have (walls are few: box sides, platens, a ring).
pub const MAX_WALLS: usize = 8;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum WallShape {
    /// A plane through `point`; particles are kept on the side `normal` points to.
    Plane { point: Vec3, normal: Vec3 },
    /// The inside of a cylinder with a vertical (z) axis through (`center.x`, `center.y`).
    Cylinder { center: Vec3, radius: f64 },
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum WallMotion {
    Fixed,
    /// Constant velocity (m/s). A cylinder's radius grows at the velocity's x component.
    Velocity(Vec3),
    /// Moves along its normal until the stress on it equals `stress` (Pa, compression > 0).
    Servo {
        stress: f64,
        max_speed: f64,
    },
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Wall {
    pub name: String,
    pub shape: WallShape,
    pub motion: WallMotion,
    /// Friction against particles; `None` uses the particle's μp.
    pub friction: Option<f64>,
    /// Area the stress is measured over (m²).
    pub area: f64,
    /// Force the particles exert on the wall during the last step (N).
    pub force: Vec3,
    /// Sum of the normal contact forces on the wall during the last step (N): the ring's
    /// radial push, a plane's normal load.
    pub normal_force: f64,
    /// Contacts and summed normal stiffness during the last step (for servo gains).
    pub contacts: u32,
    pub stiffness: f64,
    /// Velocity during the last step (m/s).
    pub velocity: Vec3,
    /// Distance moved since the wall was created (m).
    pub displacement: Vec3,
}

impl Wall {
    /// A fixed plane; `normal` points into the region particles occupy.
    pub fn plane(name: &str, point: Vec3, normal: Vec3, area: f64) -> Result<Self> {
        let len = normal.norm();
        if !(len.is_finite() && len > 0.0 && point.iter().all(|v| v.is_finite())) {
            return Err(Error::InvalidScene(format!(
                "wall `{name}`: the normal must be a finite non-zero vector and the point finite"
            )));
        }
        Ok(Self::new(name, WallShape::Plane { point, normal: normal / len }, area))
    }

    /// The inside of a vertical cylinder (axis along z).
    pub fn cylinder(name: &str, center: Vec3, radius: f64, area: f64) -> Result<Self> {
        check_positive("radius", radius, false)?;
        Ok(Self::new(name, WallShape::Cylinder { center, radius }, area))
    }

    fn new(name: &str, shape: WallShape, area: f64) -> Self {
        Wall {
            name: name.to_string(),
            shape,
            motion: WallMotion::Fixed,
            friction: None,
            area,
            force: Vec3::zeros(),
            normal_force: 0.0,
            contacts: 0,
            stiffness: 0.0,
            velocity: Vec3::zeros(),
            displacement: Vec3::zeros(),
        }
    }

    /// Compressive stress on the wall during the last step (Pa).
    pub fn stress(&self) -> f64 {
        if self.area > 0.0 {
            self.normal_force / self.area
        } else {
            0.0
        }
    }

    /// Unit normal pointing into the particles' region at `x` and the gap from the wall to
    /// the point (m): positive inside.
    #[inline(always)]
    pub fn normal_and_distance(&self, x: &Vec3) -> (Vec3, f64) {
        match &self.shape {
            WallShape::Plane { point, normal } => (*normal, (x - point).dot(normal)),
            WallShape::Cylinder { center, radius } => {
                let rho = Vec3::new(x.x - center.x, x.y - center.y, 0.0);
                let len = rho.norm();
                if len > 0.0 {
                    (-rho / len, radius - len)
                } else {
                    (Vec3::x(), *radius)
                }
            }
        }
    }

    /// Velocity of the wall surface (m/s).
    pub fn surface_velocity(&self, n: &Vec3) -> Vec3 {
        match &self.shape {
            WallShape::Plane { .. } => self.velocity,
            // A growing ring moves its surface outwards, against the inward normal.
            WallShape::Cylinder { .. } => -n * self.velocity.x,
        }
    }

    /// Moves the wall by one step: servo walls first choose their speed from the stress
    /// error of the last step (gain from the contact stiffness, so the step is stable).
    pub fn advance(&mut self, dt: f64) {
        self.velocity = match (&self.motion, &self.shape) {
            (WallMotion::Fixed, _) => Vec3::zeros(),
            (WallMotion::Velocity(v), _) => *v,
            (WallMotion::Servo { stress, max_speed }, WallShape::Plane { normal, .. }) => {
                let error_force = (stress - self.stress()) * self.area;
                let speed = if self.stiffness > 0.0 {
                    // Close 20% of the force error per step.
                    0.2 * error_force / (self.stiffness * dt)
                } else {
                    *max_speed
                };
                normal * speed.clamp(-max_speed, *max_speed)
            }
            (WallMotion::Servo { stress, max_speed }, WallShape::Cylinder { .. }) => {
                let error_force = (self.stress() - stress) * self.area;
                let speed = if self.stiffness > 0.0 { 0.2 * error_force / (self.stiffness * dt) } else { -max_speed };
                Vec3::new(speed.clamp(-max_speed, *max_speed), 0.0, 0.0)
            }
        };
        let d = self.velocity * dt;
        match &mut self.shape {
            WallShape::Plane { point, .. } => *point += d,
            WallShape::Cylinder { radius, .. } => *radius += d.x,
        }
        self.displacement += d;
    }
}
