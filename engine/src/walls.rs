//! Walls as analytic primitives: planes (box sides, platens), the inside of a vertical
//! cylinder (the oedometer ring), the outside of a cone continued by a rod (the CPT
//! penetrometer, docs/cpt.md) and plane strips (the sides of the direct shear test's
//! half-boxes, docs/direct-shear.md). A wall moves at a prescribed velocity or is servo-controlled
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
    /// The outside of a rigid cone continued by a rod (a cylinder) of the cone's base radius:
    /// the apex at `apex`, the unit `axis` from the apex towards the rod, the cone's half-angle
    /// (rad; 30° for the standard 60° cone), its base `radius` (m) and the rod's length (m)
    /// above the base, closed by a flat cap. Particles are kept outside. The loads on the cone
    /// face and on the rod are recorded apart ([`Wall::tip_force`], [`Wall::sleeve_force`]).
    /// Added after the other shapes, so checkpoints of older builds still decode.
    Cone { apex: Vec3, axis: Vec3, half_angle: f64, radius: f64, rod_length: f64 },
    /// A plane limited to a strip: the plane through `point` with unit `normal` (into the
    /// particles' region), between `lo` and `hi` (m) along the unit `axis` in the plane,
    /// measured from `point`, and unlimited across. It is the face of a solid slab behind the
    /// plane, so a grain beyond an end touches that end's face (the top of a half-box's side
    /// holds the grains that spill over it, as a real box's wall does) and a grain off a corner
    /// touches the corner's edge. Added after the cone, so older checkpoints still decode.
    Strip { point: Vec3, normal: Vec3, axis: Vec3, lo: f64, hi: f64 },
}

/// Which part of a wall a contact touches: what the cone's tip resistance and sleeve friction
/// are summed over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WallPart {
    /// A plane or a cylinder: the wall is one part.
    Whole,
    /// The cone's face, its apex and the rim where it meets the rod.
    Tip,
    /// The rod's side.
    Sleeve,
    /// The flat cap closing the rod's far end.
    Cap,
}

/// Where a point is against the body of a cone and rod, in the half-plane through its axis:
/// `s` along the axis from the apex, `rho` from the axis (≥ 0). `h` is the cone's length
/// (radius / tan(half-angle)), `end` the rod's far end (h + rod length). Returns the unit
/// normal out of the body at the nearest surface point as (along the axis, away from it), the
/// signed distance (positive outside, negative for a point inside the body) and the part.
/// The body's section is convex, so a point outside is nearest to one of the three profile
/// segments (face, rod, cap; a tie goes to the first) and a point inside to the nearest of
/// their lines.
pub fn cone_profile_distance(s: f64, rho: f64, radius: f64, h: f64, end: f64) -> ([f64; 2], f64, WallPart) {
    let slant = h.hypot(radius);
    // Outward normals of the face, the rod and the cap.
    let n_face = [-radius / slant, h / slant];
    let f_face = n_face[0] * s + n_face[1] * rho;
    let f_rod = rho - radius;
    let f_cap = s - end;
    if f_face <= 0.0 && f_rod <= 0.0 && f_cap <= 0.0 {
        // Inside: the nearest line (deepest penetration is the least negative).
        return if f_face >= f_rod && f_face >= f_cap {
            (n_face, f_face, WallPart::Tip)
        } else if f_rod >= f_cap {
            ([0.0, 1.0], f_rod, WallPart::Sleeve)
        } else {
            ([1.0, 0.0], f_cap, WallPart::Cap)
        };
    }
    // Outside: the nearest point of each segment of the profile.
    let t = ((s * h + rho * radius) / (slant * slant)).clamp(0.0, 1.0);
    let candidates = [
        ((t * h, t * radius), WallPart::Tip, n_face),
        ((s.clamp(h, end), radius), WallPart::Sleeve, [0.0, 1.0]),
        ((end, rho.clamp(0.0, radius)), WallPart::Cap, [1.0, 0.0]),
    ];
    let mut best = (f64::INFINITY, [0.0, 0.0], WallPart::Whole);
    for ((cs, cr), part, edge_normal) in candidates {
        let (ds, dr) = (s - cs, rho - cr);
        let dist = ds.hypot(dr);
        if dist < best.0 {
            // On the surface itself the edge's normal stands in for the undefined direction.
            let n = if dist > 0.0 { [ds / dist, dr / dist] } else { edge_normal };
            best = (dist, n, part);
        }
    }
    (best.1, best.0, best.2)
}

/// Where a point is against a strip's slab (see [`WallShape::Strip`]): `s` along the axis from
/// the strip's point, `h` its height over the plane (positive on the particles' side). Returns
/// the unit normal out of the slab at the nearest surface point as (along the axis, along
/// the plane's normal) and the signed distance (negative inside the slab). The slab is
/// convex: a point outside is nearest to the face, an end or a corner edge; a point inside
/// is nearest to the face or end it penetrates least.
pub fn strip_profile_distance(s: f64, h: f64, lo: f64, hi: f64) -> ([f64; 2], f64) {
    if h <= 0.0 && s >= lo && s <= hi {
        let (to_hi, to_lo) = (s - hi, lo - s);
        return if h >= to_hi && h >= to_lo {
            ([0.0, 1.0], h)
        } else if to_hi >= to_lo {
            ([1.0, 0.0], to_hi)
        } else {
            ([-1.0, 0.0], to_lo)
        };
    }
    let ds = if s > hi {
        s - hi
    } else if s < lo {
        s - lo
    } else {
        0.0
    };
    let dh = h.max(0.0);
    let dist = ds.hypot(dh);
    if dist > 0.0 {
        ([ds / dist, dh / dist], dist)
    } else {
        // On an edge itself: the face's normal stands in for the undefined direction.
        ([0.0, 1.0], 0.0)
    }
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
    /// Summed normal dashpot coefficient of the wall's contacts during the last step (N·s/m;
    /// zero without a dashpot): the servo's gain uses Σk + Σc/dt. Recomputed every step, so
    /// checkpoints do not carry it.
    #[serde(skip)]
    pub damping: f64,
    /// Velocity during the last step (m/s).
    pub velocity: Vec3,
    /// Distance moved since the wall was created (m).
    pub displacement: Vec3,
    /// A cone's tip resistance during the last step (N): the axial component (along the axis,
    /// towards the rod) of the force the particles exert on its face; zero for other shapes.
    /// Recomputed every step from the contacts, so checkpoints do not carry it (a loaded
    /// model shows it again after its first step).
    #[serde(skip)]
    pub tip_force: f64,
    /// A cone's sleeve friction force during the last step (N): the axial component of the
    /// force the particles exert on its rod (not saved, like `tip_force`).
    #[serde(skip)]
    pub sleeve_force: f64,
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

    /// A rigid cone of half-angle `half_angle` (rad) with its apex at `apex`, continued by a
    /// rod of its base radius and length `rod_length` along `axis` (from the apex towards the
    /// rod). Its area (for the stress and qc) is the cone's base, πR².
    pub fn cone(name: &str, apex: Vec3, axis: Vec3, half_angle: f64, radius: f64, rod_length: f64) -> Result<Self> {
        let len = axis.norm();
        if !(len.is_finite() && len > 0.0 && apex.iter().all(|v| v.is_finite())) {
            return Err(Error::InvalidScene(format!(
                "cone `{name}`: the axis must be a finite non-zero vector and the apex finite"
            )));
        }
        if !(half_angle > 0.0 && half_angle < std::f64::consts::FRAC_PI_2) {
            return Err(Error::InvalidScene(format!(
                "cone `{name}`: the half-angle must lie strictly between 0 and 90° (the standard cone has 30°), got \
                 {:.4}°",
                half_angle.to_degrees()
            )));
        }
        check_positive("radius", radius, false)?;
        check_positive("rod_length", rod_length, true)?;
        let area = std::f64::consts::PI * radius * radius;
        Ok(Self::new(name, WallShape::Cone { apex, axis: axis / len, half_angle, radius, rod_length }, area))
    }

    /// A plane strip (see [`WallShape::Strip`]): the plane through `point` with `normal` (into
    /// the particles' region) between `lo` and `hi` along `axis` (in the plane) from `point`.
    /// `area` is what its stress is measured over (m²; 0 for none).
    pub fn strip(name: &str, point: Vec3, normal: Vec3, axis: Vec3, lo: f64, hi: f64, area: f64) -> Result<Self> {
        let (ln, la) = (normal.norm(), axis.norm());
        let finite = point.iter().chain(normal.iter()).chain(axis.iter()).all(|v| v.is_finite());
        if !(finite && ln > 0.0 && la > 0.0) {
            return Err(Error::InvalidScene(format!(
                "strip `{name}`: the point, the normal and the axis must be finite, the normal and the axis non-zero"
            )));
        }
        let (normal, axis) = (normal / ln, axis / la);
        if normal.dot(&axis).abs() > 1e-9 {
            return Err(Error::InvalidScene(format!(
                "strip `{name}`: the axis must lie in the plane (perpendicular to the normal), got a cosine of {:.3e}                  between them",
                normal.dot(&axis)
            )));
        }
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(Error::InvalidScene(format!(
                "strip `{name}`: its ends must be finite with lo < hi along the axis, got lo {lo}, hi {hi}"
            )));
        }
        check_positive("area", area, true)?;
        Ok(Self::new(name, WallShape::Strip { point, normal, axis, lo, hi }, area))
    }

    /// A cone's tip resistance qc (Pa): the tip force over the cone's base area.
    pub fn qc(&self) -> f64 {
        match &self.shape {
            WallShape::Cone { radius, .. } => self.tip_force / (std::f64::consts::PI * radius * radius),
            _ => 0.0,
        }
    }

    /// A cone's sleeve friction fs (Pa): the sleeve force over the rod's side area (zero for
    /// a rod of no length and for other shapes).
    pub fn fs(&self) -> f64 {
        match &self.shape {
            WallShape::Cone { radius, rod_length, .. } if *rod_length > 0.0 => {
                self.sleeve_force / (2.0 * std::f64::consts::PI * radius * rod_length)
            }
            _ => 0.0,
        }
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
            damping: 0.0,
            velocity: Vec3::zeros(),
            displacement: Vec3::zeros(),
            tip_force: 0.0,
            sleeve_force: 0.0,
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
        let (n, gap, _) = self.normal_distance_part(x);
        (n, gap)
    }

    /// [`Self::normal_and_distance`] and the part of the wall nearest to `x`.
    #[inline(always)]
    pub fn normal_distance_part(&self, x: &Vec3) -> (Vec3, f64, WallPart) {
        match &self.shape {
            WallShape::Cone { apex, axis, half_angle, radius, rod_length } => {
                let d = x - apex;
                let s = d.dot(axis);
                let q = d - axis * s;
                let rho = q.norm();
                // On the axis any direction across it will do: one fixed by the axis alone.
                let e = if rho > 0.0 { q / rho } else { across(axis) };
                let h = radius / half_angle.tan();
                let (n, gap, part) = cone_profile_distance(s, rho, *radius, h, h + rod_length);
                (axis * n[0] + e * n[1], gap, part)
            }
            WallShape::Strip { point, normal, axis, lo, hi } => {
                let d = x - point;
                let (n, gap) = strip_profile_distance(d.dot(axis), d.dot(normal), *lo, *hi);
                (axis * n[0] + normal * n[1], gap, WallPart::Whole)
            }
            _ => {
                let (n, gap) = self.plane_or_cylinder(x);
                (n, gap, WallPart::Whole)
            }
        }
    }

    #[inline(always)]
    fn plane_or_cylinder(&self, x: &Vec3) -> (Vec3, f64) {
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
            WallShape::Cone { .. } | WallShape::Strip { .. } => {
                unreachable!("cones and strips are measured by normal_distance_part")
            }
        }
    }

    /// A cone's unit axis (from the apex towards the rod); `None` for other shapes.
    pub fn axis(&self) -> Option<Vec3> {
        match &self.shape {
            WallShape::Cone { axis, .. } => Some(*axis),
            _ => None,
        }
    }

    /// Velocity of the wall surface (m/s).
    pub fn surface_velocity(&self, n: &Vec3) -> Vec3 {
        match &self.shape {
            WallShape::Plane { .. } | WallShape::Cone { .. } | WallShape::Strip { .. } => self.velocity,
            // A growing ring moves its surface outwards, against the inward normal.
            WallShape::Cylinder { .. } => -n * self.velocity.x,
        }
    }

    /// The servo's effective contact stiffness (N/m): moving the wall by Δx in one step changes
    /// the force of its contacts by Σk·Δx through the springs and by Σc·Δx/dt at once through
    /// the dashpots, so a gain from Σk alone overshoots wherever Σc/dt is not small beside it.
    pub fn servo_stiffness(&self, dt: f64) -> f64 {
        self.stiffness + self.damping / dt
    }

    /// Moves the wall by one step: servo walls first choose their speed from the stress
    /// error of the last step (gain from the contacts' stiffness and dashpots, so the step is
    /// stable).
    pub fn advance(&mut self, dt: f64) {
        let k = self.servo_stiffness(dt);
        self.velocity = match (&self.motion, &self.shape) {
            (WallMotion::Fixed, _) => Vec3::zeros(),
            (WallMotion::Velocity(v), _) => *v,
            (WallMotion::Servo { stress, max_speed }, WallShape::Plane { normal, .. }) => {
                let error_force = (stress - self.stress()) * self.area;
                // Close 20% of the force error per step.
                let speed = if k > 0.0 { 0.2 * error_force / (k * dt) } else { *max_speed };
                normal * speed.clamp(-max_speed, *max_speed)
            }
            (WallMotion::Servo { stress, max_speed }, WallShape::Cylinder { .. }) => {
                let error_force = (self.stress() - stress) * self.area;
                let speed = if k > 0.0 { 0.2 * error_force / (k * dt) } else { -max_speed };
                Vec3::new(speed.clamp(-max_speed, *max_speed), 0.0, 0.0)
            }
            // Hosts refuse a servo on a cone or a strip (they are pushed at a prescribed speed).
            (WallMotion::Servo { .. }, WallShape::Cone { .. } | WallShape::Strip { .. }) => Vec3::zeros(),
        };
        let d = self.velocity * dt;
        match &mut self.shape {
            WallShape::Plane { point, .. } => *point += d,
            WallShape::Cylinder { radius, .. } => *radius += d.x,
            WallShape::Cone { apex, .. } => *apex += d,
            WallShape::Strip { point, .. } => *point += d,
        }
        self.displacement += d;
    }
}

/// A unit vector across `axis` (unit), fixed by the axis alone (the GPU picks the same one).
fn across(axis: &Vec3) -> Vec3 {
    let helper = if axis.x.abs() < 0.9 { Vec3::x() } else { Vec3::y() };
    axis.cross(&helper).normalize()
}
