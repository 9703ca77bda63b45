//! A confining pressure on the side of a cylindrical sample (issue 34 item 4): a triaxial cell's
//! membrane and water as a pressure boundary. Each step the membrane finds the grains it touches —
//! in each cell of its surface the one reaching farthest from the axis — and pushes each towards
//! the axis with the pressure times its patch of membrane (`physics.rs`). An optional force stage:
//! a scene that does not confine a sample has no pass and no pipeline for it; it keeps no
//! per-particle lanes (the GPU keeps three words per cell).
//!
//! **Why a pressure boundary and not bonded membrane elements.** MatDEM's triaxial tester
//! applies the confining water pressure to the sample's surface; a membrane of bonded elements
//! would add its own stiffness to the sample's lateral response (and needs its stiffness
//! calibrated away), while the pressure boundary holds σ3 exactly on whatever surface the
//! sample takes, barrelling or shearing, with no parameter but the cells' size (a grain
//! diameter: smaller cells leave some empty, larger ones let grains bulge between the touched).
//!
//! The effect's folder: the membrane's geometry and load (`physics.rs`), the scene's settings
//! (`settings.rs`, part of [`crate::model::Settings`]), the CPU pass (`cpu.rs`) and the GPU
//! kernels (`gpu.rs`, with `shaders/confining_pressure.wgsl`).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod physics;
pub mod settings;
pub mod state;

use crate::effects::confining_pressure::physics::{picks, Cells, NONE};
pub use crate::effects::confining_pressure::settings::{Confinement, MAX_CELLS};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::state::particles::dof;
use crate::walls::{Wall, WallShape};

/// What a plan with the `confining_pressure` stage runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConfiningPlan {
    pub pressure: f64,
    pub axis: [f64; 2],
    /// The platens' wall indices.
    pub bottom: usize,
    pub top: usize,
    pub bands: u32,
    pub sectors: u32,
    /// A 2D model's plate thickness (m): the membrane is its two sides.
    pub thickness: Option<f64>,
}

impl ConfiningPlan {
    /// The plan's confinement, when the scene confines a sample.
    pub fn of(m: &Model) -> Option<Self> {
        let c = m.effects.confining_pressure.confinement.as_ref()?;
        Some(ConfiningPlan {
            pressure: c.pressure,
            axis: c.axis,
            bottom: m.wall_index(&c.bottom).ok()?,
            top: m.wall_index(&c.top).ok()?,
            bands: c.bands,
            sectors: c.sectors,
            thickness: m.settings.planar.map(|p| p.thickness),
        })
    }

    /// The membrane's cells with the platens where `walls` has them now.
    pub fn cells(&self, walls: &[Wall]) -> Cells {
        let (z0, z1) = (plane_height(&walls[self.bottom]), plane_height(&walls[self.top]));
        match self.thickness {
            Some(t) => Cells::planar(self.bands, self.axis[0], z0, z1, t),
            None => Cells::new(self.bands, self.sectors, self.axis, z0, z1),
        }
    }

    /// The stage in the plan's words.
    pub fn words(&self) -> String {
        format!(
            "confining pressure(σ3 = {:.4e} Pa on the grains the membrane touches, {} bands × {} sectors)",
            self.pressure, self.bands, self.sectors
        )
    }
}

/// A plane wall's height (its point's z): the platens are horizontal planes.
fn plane_height(w: &Wall) -> f64 {
    match &w.shape {
        WallShape::Plane { point, .. } => point.z,
        _ => f64::NAN,
    }
}

/// What a script asks for: the pressure, the platens' names, the axis, and optionally the cells.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfineRequest {
    pub pressure: f64,
    pub bottom: String,
    pub top: String,
    pub axis: [f64; 2],
    pub bands: Option<u32>,
    pub sectors: Option<u32>,
}

/// The membrane as it stands: what a triaxial test reads for σ3 and the volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Membrane {
    pub pressure: f64,
    pub cells: usize,
    /// Cells with a grain under them, and empty cells whose patch a touched neighbour carries
    /// (`physics::shares`); an empty cell with no touched neighbour pushes nothing.
    pub touched: usize,
    pub covered: usize,
    /// Mean reach ρ + r of the touched grains: the membrane's radius (m).
    pub radius: f64,
    /// Height between the platens (m).
    pub height: f64,
    /// The loaded patches' area, Σ (1 + shares)·(ρ + r)·Δθ·Δz (m²), and the load on them,
    /// Σ|F| = σ·area (N).
    pub area: f64,
    pub load: f64,
    /// The lateral stress the membrane applies: the load over the side of a cylinder of the
    /// membrane's radius and height, 2π·R·H (Pa): σ3 when every cell is touched or covered.
    pub stress: f64,
    /// The volume inside the membrane, Σ (1 + shares)·½·(ρ + r)²·Δθ·Δz over the touched cells,
    /// an empty cell no neighbour covers counted at the mean reach (m³): a triaxial test's
    /// volumetric strain.
    pub volume: f64,
}

impl Model {
    /// Confines the sample between two horizontal plane walls with a pressure on its side (the
    /// `confining_pressure` stage), replacing any confinement it had. Without `bands`/`sectors`
    /// the cells are about one mean grain diameter high and wide at the sample's outer radius.
    pub fn confine(&mut self, req: ConfineRequest) -> Result<()> {
        let planar = self.settings.planar.is_some();
        if planar && req.sectors.is_some_and(|s| s != 2) {
            return Err(Error::InvalidScene(format!(
                "confining pressure: a 2D model's membrane is its two sides (2 sectors), not {}; leave sectors out",
                req.sectors.unwrap_or_default()
            )));
        }
        let p = req.pressure;
        // Above 1e11 Pa (100 GPa, a hundred times any rock's strength) a membrane force
        // σ3·(ρ + r)·Δθ·Δz can leave the numbers.
        if !(p > 0.0 && p <= 1e11) {
            return Err(Error::InvalidScene(format!(
                "confining pressure = {p:e}: give a pressure in Pa above 0 and at most 1e11 (a triaxial cell's σ3 is \
                 kPa to a few hundred MPa; d.unconfine() removes it)"
            )));
        }
        if !req.axis.iter().all(|v| v.is_finite()) {
            return Err(Error::InvalidScene(format!("confining pressure: axis {:?} must be finite (m)", req.axis)));
        }
        let mut z = [0.0; 2];
        for (k, (name, up)) in [(&req.bottom, 1.0), (&req.top, -1.0)].into_iter().enumerate() {
            let w = &self.walls[self.wall_index(name)?];
            match &w.shape {
                WallShape::Plane { point, normal } if normal.z * up > 0.999 => z[k] = point.z,
                _ => {
                    let which = if k == 0 { "below" } else { "above" };
                    return Err(Error::InvalidScene(format!(
                        "confining pressure: wall `{name}` must be a horizontal plane {which} the sample facing it \
                         (normal {}z), as a box's `bottom` and `top_platen` are",
                        if k == 0 { "+" } else { "−" }
                    )));
                }
            }
        }
        if z[1] <= z[0] {
            return Err(Error::InvalidScene(format!(
                "confining pressure: `{}` (z = {}) must be above `{}` (z = {})",
                req.top, z[1], req.bottom, z[0]
            )));
        }
        let live: Vec<usize> = (0..self.len()).filter(|&i| self.particles.fixed[i] & dof::KILLED == 0).collect();
        if live.is_empty() {
            return Err(Error::InvalidScene("confining pressure: the model has no elements to confine".into()));
        }
        let p_ = &self.particles;
        let diameter = 2.0 * live.iter().map(|&i| p_.radius[i]).sum::<f64>() / live.len() as f64;
        let reach = live
            .iter()
            .map(|&i| (p_.pos[i].x - req.axis[0]).hypot(p_.pos[i].y - req.axis[1]) + p_.radius[i])
            .fold(0.0, f64::max);
        let bands = req.bands.unwrap_or(((z[1] - z[0]) / diameter).round().max(1.0) as u32);
        let sectors = if planar {
            2
        } else {
            req.sectors.unwrap_or((std::f64::consts::TAU * reach / diameter).round().max(6.0) as u32)
        };
        if bands == 0 || sectors == 0 || bands as usize * sectors as usize > MAX_CELLS {
            return Err(Error::InvalidScene(format!(
                "confining pressure: {bands} bands × {sectors} sectors; give at least 1 of each and at most \
                 {MAX_CELLS} cells (a cell about one grain diameter, {diameter:.3e} m, suits)"
            )));
        }
        self.effects.confining_pressure.confinement =
            Some(Confinement { pressure: p, axis: req.axis, bottom: req.bottom, top: req.top, bands, sectors });
        self.touch();
        Ok(())
    }

    /// Removes the confining pressure.
    pub fn unconfine(&mut self) {
        if self.effects.confining_pressure.confinement.take().is_some() {
            self.touch();
        }
    }

    /// The membrane as the grains stand now (`None` without confinement).
    pub fn membrane(&self) -> Option<Membrane> {
        let plan = ConfiningPlan::of(self)?;
        let cells = plan.cells(&self.walls);
        let p = &self.particles;
        let (best, shares) = picks(&cells, p);
        // (reach, patches) of each touched cell.
        let touched: Vec<(f64, f64)> =
            best.iter().zip(&shares).filter(|(b, _)| b.0 != NONE).map(|(b, &k)| (b.1, f64::from(1 + k))).collect();
        let covered = shares.iter().sum::<u32>() as usize;
        let radius =
            if touched.is_empty() { 0.0 } else { touched.iter().map(|t| t.0).sum::<f64>() / touched.len() as f64 };
        let area: f64 = touched.iter().map(|&(r, k)| k * cells.patch(r)).sum();
        let height = cells.dz * f64::from(cells.bands);
        let lost = (best.len() - touched.len() - covered) as f64;
        let volume = touched.iter().map(|&(r, k)| k * cells.volume(r)).sum::<f64>() + lost * cells.volume(radius);
        let side = cells.side(radius);
        Some(Membrane {
            pressure: plan.pressure,
            cells: best.len(),
            touched: touched.len(),
            covered,
            radius,
            height,
            area,
            load: plan.pressure * area,
            stress: if side > 0.0 { plan.pressure * area / side } else { 0.0 },
            volume,
        })
    }

    /// The confining fluid's potential σ·V, V the volume over the touched cells (J; 0 without
    /// confinement): the membrane's loads are its gradient while no grain changes cell.
    pub fn confining_potential(&self) -> f64 {
        let Some(plan) = ConfiningPlan::of(self) else { return 0.0 };
        let cells = plan.cells(&self.walls);
        let p = &self.particles;
        let (best, shares) = picks(&cells, p);
        let volume =
            best.iter().zip(&shares).filter(|(b, _)| b.0 != NONE).map(|(b, &k)| f64::from(1 + k) * cells.volume(b.1));
        plan.pressure * volume.sum::<f64>()
    }
}
