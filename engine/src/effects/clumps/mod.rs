//! Clumps (issue 34 item 3): rigid groups of overlapping or touching elements that move as one
//! body. A clump's members keep their own contacts with everything outside the clump (that is
//! how clumps touch each other and the walls), have none among themselves (the neighbour rows
//! leave such pairs out), and are not integrated one by one: the `clumps` stage, right after the
//! move, sums each clump's member forces and torques about its centre, advances the body
//! (`physics.rs`: leapfrog translation, angular momentum kicked by the torque and the orientation
//! turned by the split free rotation) and places its members where the body carries them, with
//! the velocities of its rigid motion.
//!
//! Mass, centre and inertia come from the members' spheres (exact when they do not overlap, by
//! voxels when they do: `physics::mass_properties`); the members keep their own masses for
//! their contacts' damping and the critical time step. Gravity acts on the clump's mass;
//! Cundall's local damping on each component of its force and torque; global viscous damping as
//! the members' dashpots summed (the same rate on its angular momentum).
//!
//! In a 2D model a clump turns about y alone: its frame is an exact turn about y and the stage
//! holds its force along y and torque about x and z at zero, as the integration holds a 2D
//! model's elements (`physics::principal_axes_in_plane`).
//!
//! An optional stage: a scene without clumps has no pass, no pipeline and no lanes; the
//! members' mark is a bit of the `fixed` lane the integration already reads.
//!
//! The effect's folder: the body mechanics (`physics.rs`), the state (`lanes.rs`, part of
//! [`Model`]), the CPU pass (`cpu.rs`) and the GPU kernel (`gpu.rs`, `shaders/clumps.wgsl`).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod lanes;
pub mod physics;
pub mod template;

use crate::effects::clumps::lanes::{Body, Clumps, NONE};
use crate::effects::clumps::physics::{mass_properties, principal_axes, principal_axes_in_plane, Sphere};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::physics::Vec3;
use crate::state::particles::dof;

/// What a plan with the `clumps` stage runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClumpsPlan {
    pub clumps: usize,
    pub members: usize,
}

impl ClumpsPlan {
    pub fn of(m: &Model) -> Option<Self> {
        (!m.clumps.is_empty()).then(|| ClumpsPlan { clumps: m.clumps.len(), members: m.clumps.members.len() })
    }

    pub fn words(&self) -> String {
        format!("clumps({} rigid bodies of {} elements)", self.clumps, self.members)
    }
}

/// A clump as a script reads it.
#[derive(Debug, Clone, PartialEq)]
pub struct ClumpInfo {
    pub members: Vec<u32>,
    pub mass: f64,
    pub centre: Vec3,
    pub velocity: Vec3,
    pub ang_vel: Vec3,
    pub ang_mom: Vec3,
    /// Principal moments (kg·m²): ascending at creation in 3D; about body x, y (the model's y),
    /// z in 2D.
    pub inertia: Vec3,
    pub orientation: [f64; 4],
}

impl Model {
    /// Makes elements `ids` one clump and returns its number. The body takes the members'
    /// momentum and angular momentum about its centre; from then on they move as one. The
    /// members must be live, free (no fixed degree of freedom) and in no clump yet. Switches
    /// rotation on (a member's contacts turn it).
    pub fn clump(&mut self, ids: &[u32]) -> Result<usize> {
        self.check_ids(ids)?;
        let mut ids = ids.to_vec();
        ids.sort_unstable();
        ids.dedup();
        if ids.is_empty() {
            return Err(Error::InvalidScene("clump: give at least one element".into()));
        }
        for &i in &ids {
            let i = i as usize;
            if self.clumps.clump_of(i).is_some() {
                return Err(Error::InvalidScene(format!(
                    "clump: element {i} is in clump {} already; an element belongs to one clump",
                    self.clumps.of[i]
                )));
            }
            // A 2D model's elements are held in y and in spin about x and z: so is its clump.
            let held = if self.settings.planar.is_some() { crate::planar::HELD } else { 0 };
            if self.particles.fixed[i] & !held != 0 {
                return Err(Error::InvalidScene(format!(
                    "clump: element {i} is killed or has a fixed degree of freedom; clump free elements (unfix them first)"
                )));
            }
        }
        // In a periodic cell the members may lie on either side of a face: each is brought to
        // the image nearest the first, so that they are one body (the cell wraps its centre).
        if let Some(cell) = self.effects.periodic.cell {
            let image = cell.image();
            let first = self.particles.pos[ids[0] as usize];
            let p = &mut self.particles;
            for &i in &ids[1..] {
                let i = i as usize;
                let moved = first + image.nearest(p.pos[i] - first) - p.pos[i];
                p.pos[i] += moved;
                p.origin[i] += moved;
            }
        }
        let p = &self.particles;
        let spheres: Vec<Sphere> = ids
            .iter()
            .map(|&i| {
                let (i, r) = (i as usize, p.radius[i as usize]);
                Sphere {
                    centre: p.pos[i],
                    radius: r,
                    density: p.mass[i] / (4.0 / 3.0 * std::f64::consts::PI * r * r * r),
                }
            })
            .collect();
        let mut props = mass_properties(&spheres);
        if self.settings.planar.is_some() {
            // The voxels' sums leave round-off off the plane: a 2D clump's centre is on it.
            props.centre.y = 0.0;
        }
        let (inertia, q) = match self.settings.planar {
            Some(_) => principal_axes_in_plane(&props.inertia),
            None => principal_axes(&props.inertia),
        };
        let c = props.centre;
        // The members' momentum and angular momentum about the centre, taken over by the body.
        let member_mass: f64 = ids.iter().map(|&i| p.mass[i as usize]).sum();
        let vel = ids.iter().map(|&i| p.vel[i as usize] * p.mass[i as usize]).sum::<Vec3>() / member_mass;
        let mut ang_mom = Vec3::zeros();
        for &i in &ids {
            let i = i as usize;
            ang_mom += (p.pos[i] - c).cross(&(p.vel[i] - vel)) * p.mass[i];
            if let Some(r) = &p.rotation {
                ang_mom += r.ang_vel[i] * p.inertia(i);
            }
        }
        let mut body = Body { mass: props.mass, inertia, pos: c, vel, orientation: [1.0, 0.0, 0.0, 0.0], ang_mom };
        body.set_rotation(q);
        let number = self.clumps.len();
        let n = self.len();
        let cl = &mut self.clumps;
        if cl.of.len() != n {
            cl.of.resize(n, NONE);
        }
        if cl.member_start.is_empty() {
            cl.member_start.push(0);
        }
        for &i in &ids {
            cl.members.push(i);
            cl.offsets.push(q.inverse_transform_vector(&(self.particles.pos[i as usize] - c)));
            cl.of[i as usize] = number as u32;
            self.particles.fixed[i as usize] |= dof::CLUMPED;
        }
        cl.member_start.push(cl.members.len() as u32);
        cl.bodies.push(body);
        self.settings.rotation = true;
        if self.particles.rotation.is_none() {
            self.particles.enable_rotation();
        }
        cpu::place_members(self, number);
        if let Some(cell) = self.effects.periodic.cell {
            crate::effects::periodic::wrap::wrap_clump(&cell, &mut self.clumps, &mut self.particles, number);
        }
        // The members' pairs among themselves leave the rows (with any bond between them).
        self.contacts.stale = true;
        crate::neighbours::rebuild(self);
        self.touch();
        Ok(number)
    }

    /// Clump c as it stands.
    pub fn clump_info(&self, c: usize) -> Result<ClumpInfo> {
        let cl = &self.clumps;
        let b = cl.bodies.get(c).ok_or_else(|| {
            Error::InvalidScene(format!("clump {c}: the model has {} clump(s), numbered from 0", cl.len()))
        })?;
        Ok(ClumpInfo {
            members: cl.members[cl.range(c)].to_vec(),
            mass: b.mass,
            centre: b.pos,
            velocity: b.vel,
            ang_vel: b.ang_vel(),
            ang_mom: b.ang_mom,
            inertia: b.inertia,
            orientation: b.orientation,
        })
    }

    /// Takes elements out of their clumps (they are being removed or killed): each clump that
    /// loses members is made again from the rest, keeping its velocity and angular velocity; a
    /// clump that loses all goes. `map` renumbers the survivors (`None`: removed), or is `None`
    /// when no element is renumbered.
    pub(crate) fn detach_from_clumps(&mut self, leaving: &[bool], map: Option<&[Option<u32>]>) {
        if self.clumps.is_empty() {
            return;
        }
        let old = std::mem::take(&mut self.clumps);
        let renumber = |i: u32| match map {
            Some(m) => m[i as usize],
            None => Some(i),
        };
        let n = self.len();
        for (c, body) in old.bodies.iter().enumerate() {
            let range = old.range(c);
            let kept: Vec<u32> = old.members[range.clone()]
                .iter()
                .filter(|&&i| !leaving[i as usize])
                .filter_map(|&i| renumber(i))
                .collect();
            if kept.len() == range.len() {
                // Untouched: carried over as it is (renumbered).
                let cl = &mut self.clumps;
                if cl.member_start.is_empty() {
                    cl.member_start.push(0);
                    cl.of = vec![NONE; n];
                }
                let number = cl.bodies.len() as u32;
                for (&i, o) in kept.iter().zip(&old.offsets[range]) {
                    cl.members.push(i);
                    cl.offsets.push(*o);
                    cl.of[i as usize] = number;
                }
                cl.member_start.push(cl.members.len() as u32);
                cl.bodies.push(body.clone());
                continue;
            }
            let w = body.ang_vel();
            for &i in &kept {
                self.particles.fixed[i as usize] &= !dof::CLUMPED;
            }
            if kept.is_empty() {
                continue;
            }
            // Made again from the rest with the old body's rigid motion.
            for &i in &kept {
                let i = i as usize;
                self.particles.vel[i] = body.vel + w.cross(&(self.particles.pos[i] - body.pos));
                if let Some(r) = &mut self.particles.rotation {
                    r.ang_vel[i] = w;
                }
            }
            let made = self.clump(&kept);
            debug_assert!(made.is_ok(), "the rest of a clump is free and live");
        }
        // Elements renumbered or gone: the clump marks of the others were reset above.
        if self.clumps.is_empty() {
            self.clumps = Clumps::default();
        }
    }
}
