//! 2D models (MatDEM's `B.sampleL = 0`): one layer of spheres in the x–z plane, every centre
//! at y = 0, moving in x and z and turning about y only. Contacts and walls are the 3D ones;
//! what changes is what the model holds still, how it is measured and how its materials convert:
//!
//! - every element has y, and spin about x and z, held ([`HELD`] in its `fixed` bits, which a
//!   script cannot free): both backends' integration keep those components as they are, zero,
//!   so a 2D model stays in its plane to the bit (the forces of spheres whose centres lie at
//!   y = 0 have no y component, and their torques only one about y);
//! - the neighbour search finds one layer of cells (the packing has no extent in y), and the
//!   contact pass computes in the plane: the CPU's pair lanes carry x and z only (`V4<true>`),
//!   the GPU's contact kernel reads its vectors with y a literal zero (`in_plane`), so a 2D
//!   scene does not pay for a third component there (the scalar law of bonded pairs, the
//!   gather and the integration still compute in 3D with zeros);
//! - the model is a plate of `thickness` (by default the mean element diameter): stresses are
//!   forces over length × thickness, porosity is by area in the plane ([`area`]);
//! - materials convert with the hexagonal lattice's formulas ([`conversion`]).

pub mod area;
pub mod conversion;
pub mod porosity;
pub mod setting;

pub use setting::{Planar, HELD};

use crate::error::{Error, Result};
use crate::geometry::region::Region;
use crate::model::Model;
use crate::physics::Vec3;

impl Model {
    /// Makes the model 2D (x–z plane) with a plate `thickness` (m; by default the mean element
    /// diameter). Every element must lie at y = 0: a 3D packing cannot be flattened without
    /// overlaps, so build the model 2D (`sample_l = 0`, a 2D geometry) instead. Elements added
    /// later must lie at y = 0 too.
    pub fn make_planar(&mut self, thickness: Option<f64>) -> Result<()> {
        let t = match thickness {
            Some(t) => t,
            None if !self.is_empty() => 2.0 * self.mean_radius(),
            None => {
                return Err(Error::InvalidScene(
                    "a 2D model without elements needs its thickness: give it, or add the elements first".into(),
                ))
            }
        };
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::param(
                "thickness",
                t,
                "must be a finite length > 0 m (the mean element diameter, as MatDEM)",
            ));
        }
        if self.effects.confining_pressure.confinement.is_some() || self.pores.is_some() {
            return Err(Error::InvalidScene(
                "the model has a confining pressure set round a 3D cylinder, or pore flow, which needs 3D: remove \
                 them (d.unconfine(), d.disable(\"pore_flow\")) before making it 2D, then confine the 2D model again"
                    .into(),
            ));
        }
        let p = &mut self.particles;
        if let Some(i) = p.pos.iter().position(|x| x.y != 0.0) {
            return Err(Error::InvalidScene(format!(
                "element {i} lies at y = {:e} m: a 2D model has every centre at y = 0; build it 2D \
                 (a box with sample_l = 0, or a 2D geometry) instead of flattening a 3D packing",
                p.pos[i].y
            )));
        }
        for i in 0..p.len() {
            p.fixed[i] |= HELD;
            p.vel[i].y = 0.0;
        }
        if let Some(r) = &mut p.rotation {
            for w in &mut r.ang_vel {
                (w.x, w.z) = (0.0, 0.0);
            }
        }
        self.settings.planar = Some(Planar { thickness: t });
        self.touch();
        Ok(())
    }

    /// The 2D setting, when the model is 2D.
    pub fn planar(&self) -> Option<Planar> {
        self.settings.planar
    }

    /// Refuses an element off a 2D model's plane (`add_particle` checks it).
    pub(crate) fn check_in_plane(&self, pos: &Vec3) -> Result<()> {
        if self.settings.planar.is_some() && pos.y != 0.0 {
            return Err(Error::InvalidScene(format!(
                "the model is 2D (x–z plane): an element at y = {:e} m is off it; give y = 0",
                pos.y
            )));
        }
        Ok(())
    }

    /// The volume a region stands for: its own in 3D, its cut by the plane y = 0 times the
    /// thickness in 2D (m³). Stresses from contact forces divide by it.
    pub fn region_volume(&self, region: &Region) -> f64 {
        match self.settings.planar {
            Some(p) => porosity::section_area(region) * p.thickness,
            None => region.volume(),
        }
    }

    /// Whether element `i` is free to move where the model lets it: no fixed degree of freedom
    /// but those a 2D model holds for all. Statistics of balance (the unbalanced force ratio)
    /// count these.
    pub fn is_free(&self, i: usize) -> bool {
        let held = if self.settings.planar.is_some() { HELD } else { 0 };
        self.particles.fixed[i] & !held == 0
    }
}
