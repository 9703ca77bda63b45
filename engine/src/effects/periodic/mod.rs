//! Periodic boundaries (issue 34 item 2; MatDEM 5's `addPeriodBoundary`): along any of x, y, z
//! the model repeats with a span L, so an element near one face touches the elements near the
//! other through their images. Pairs interact through the nearest image (the minimum-image
//! convention, exact while L exceeds twice the largest pair distance, which [`Model::periodic`]
//! checks): the neighbour search wraps its cells round the periodic axes, the pair pass measures
//! each pair through its nearest image, and so does everything that measures a pair (energies,
//! guard, bonding, contact lists). A bond or a pair's shear spring is a pair's, whichever image
//! it acts through, so it is carried across a face as it is anywhere else.
//!
//! The `periodic` stage, right after the move, puts each element that left the cell back in
//! through the opposite face (its displacement's origin moves with it, so displacement fields
//! stay continuous); velocity, spin and every other lane are untouched, to the bit.
//!
//! With x and z periodic the cell may shear by Lees–Edwards images ([`Model::lees_edwards`]):
//! the image one span up slides along x at γ̇·L_z, a pair across a z face measures through the
//! slid image and gains its velocity, and an element crossing a z face continues as that image
//! (`setting.rs`). Both backends: on the GPU each step's offset reaches the kernels through the
//! params (`gpu.rs`).
//!
//! An optional stage: a scene without periodic axes has no pass, and its pair loop no test for
//! it (the pair pass is compiled once with the image and once without, and picks per pass).
//!
//! The effect's folder: the cell and its arithmetic (`setting.rs`, part of
//! [`crate::model::Settings`]), the CPU pass (`cpu.rs`) and the GPU kernel (`gpu.rs`,
//! `shaders/periodic.wgsl`).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod setting;
pub mod state;
pub mod wrap;

pub use setting::{Image, Periodic, Separations};

use crate::error::{Error, Result};
use crate::model::Model;
use crate::physics::Vec3;

impl Model {
    /// Makes the axes with a span periodic (`axes[k] = Some([lo, hi])`), replacing any earlier
    /// cell; every element is put into the cell. Each span must be at least three cell-list
    /// cells, 3·(2·r_max + skin), so that the nearest image of every pair in reach is its only
    /// one in reach; effects whose pairs do not yet measure through images are refused.
    pub fn periodic(&mut self, axes: [Option<[f64; 2]>; 3]) -> Result<()> {
        if axes.iter().all(Option::is_none) {
            return Err(Error::InvalidScene("periodic: give at least one axis, e.g. #{ x: [x0, x1] }".into()));
        }
        if self.contacts.skin <= 0.0 && !self.is_empty() {
            self.contacts.skin = self.settings.skin_ratio * self.mean_radius();
        }
        let r_max = self.particles.radius.iter().copied().fold(0.0, f64::max);
        let least = 3.0 * (2.0 * r_max + self.contacts.skin);
        for (name, axis) in ["x", "y", "z"].iter().zip(&axes) {
            let Some([lo, hi]) = *axis else { continue };
            if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                return Err(Error::InvalidScene(format!(
                    "periodic: {name} = [{lo}, {hi}] must be two finite coordinates, the first below the second (m)"
                )));
            }
            if hi - lo < least {
                return Err(Error::InvalidScene(format!(
                    "periodic: the span of {name}, {:.4e} m, must be at least 3·(2·r_max + skin) = {least:.4e} m \
                     (three neighbour cells, so that a pair meets through one image only); widen the cell or use \
                     smaller elements",
                    hi - lo
                )));
            }
        }
        if self.settings.planar.is_some() && axes[1].is_some() {
            return Err(Error::InvalidScene(
                "periodic: a 2D model lies in the x–z plane; make x or z periodic, not y".into(),
            ));
        }
        let cell = Periodic { axes, shear: None };
        check_effects(self)?;
        wrap::wrap_all(&cell, &mut self.particles, &mut self.clumps);
        self.effects.periodic.cell = Some(cell);
        self.contacts.stale = true;
        crate::neighbours::rebuild(self);
        self.touch();
        Ok(())
    }

    /// Shears the periodic cell at γ̇ = `rate` (1/s) by Lees–Edwards' images: x flows along z,
    /// the image one cell up sliding along x at γ̇·L_z, so the packing shears homogeneously with
    /// no wall. Both x and z must be periodic. The elements keep their velocities: give them the
    /// streaming profile v_x = γ̇·(z − z_mid) to start in steady shear. A rate of 0 stops the
    /// slide where it is (the images stay offset). Both backends.
    pub fn lees_edwards(&mut self, rate: f64) -> Result<()> {
        let Some(cell) = self.effects.periodic.cell.as_mut() else {
            return Err(Error::InvalidScene(
                "Lees–Edwards shear slides a periodic cell's images: make x and z periodic first (d.periodic)".into(),
            ));
        };
        if cell.axes[0].is_none() || cell.axes[2].is_none() {
            return Err(Error::InvalidScene(
                "Lees–Edwards shear: x flows along z, so both x and z must be periodic (d.periodic(#{ x: …, z: … }))"
                    .into(),
            ));
        }
        if !rate.is_finite() {
            return Err(Error::InvalidScene(format!("Lees–Edwards shear: the rate {rate} must be a finite γ̇ (1/s)")));
        }
        let (offset, offset_at_build) = cell.shear.map_or((0.0, 0.0), |s| (s.offset, s.offset_at_build));
        cell.shear = Some(setting::Shear { rate, offset, offset_at_build });
        self.touch();
        Ok(())
    }

    /// Makes every axis non-periodic again (elements stay where the cell put them).
    pub fn unperiodic(&mut self) {
        if self.effects.periodic.cell.take().is_some() {
            self.contacts.stale = true;
            self.touch();
        }
    }

    /// From element i to element j, through the nearest image in a periodic cell.
    pub fn separation(&self, i: usize, j: usize) -> Vec3 {
        self.separations().between(&self.particles.pos, i, j)
    }

    /// The model's pair separation, for a loop over many pairs (the cell's image worked out
    /// once).
    pub fn separations(&self) -> Separations {
        Separations::of(self.effects.periodic.cell.as_ref())
    }
}

/// The effects whose pairs or geometry do not yet measure through a periodic cell's images.
fn check_effects(m: &Model) -> Result<()> {
    let s = &m.settings;
    let blocked =
        [(s.pores.enabled, "pore flow"), (m.effects.confining_pressure.confinement.is_some(), "a confining pressure")];
    match blocked.iter().find(|(on, _)| *on) {
        Some((_, what)) => Err(Error::InvalidScene(format!(
            "periodic boundaries do not yet work with {what}: run the scene without one of them"
        ))),
        None => Ok(()),
    }
}

/// Refuses a run whose scene has periodic axes and an effect that does not work with them yet
/// (switched on after the cell was made), or a sliding Lees–Edwards cell with damping that
/// acts on whole velocities.
pub fn check_scene(m: &Model) -> Result<()> {
    let Some(cell) = m.effects.periodic.cell else { return Ok(()) };
    check_effects(m)?;
    if cell.shear.is_some_and(|s| s.rate != 0.0) {
        // Both act on an element's whole velocity, the shear's stream v_x = γ̇·z included,
        // so they would drag the packing towards rest instead of damping its fluctuations.
        let s = &m.settings;
        let damping = [(s.local_damping, "local damping (−α·|F|·sign(v))"), (s.damping, "viscous damping (−c·v)")];
        if let Some((_, what)) = damping.iter().find(|(on, _)| *on > 0.0) {
            return Err(Error::InvalidScene(format!(
                "Lees–Edwards shear: {what} acts on each element's whole velocity, so it would brake the \
                 shear's streaming profile v_x = γ̇·z like a drag; set it to 0 while the cell slides (the \
                 contacts' damping and friction take the heat of shearing), or stop the slide \
                 (d.lees_edwards(0)) to balance with it"
            )));
        }
    }
    Ok(())
}

/// What a plan with the `periodic` stage runs.
pub fn words(cell: &Periodic) -> String {
    cell.words()
}
