//! Pore density flow (paper 003, §3.3): fluid in the pores of the packing.
//!
//! - [`delaunay`]: the Delaunay tetrahedralisation of element centres.
//! - [`geometry`]: pore volume (tetrahedron minus sphere sectors), throat opening (face
//!   minus circle sectors), the Poiseuille-type throat conductance.
//! - [`network`]: pores (tetrahedra, slivers merged) and throats (faces between pores).
//! - [`flow`]: fluid mass per pore, density = mass / pore volume, pressure from the equation
//!   of state p = K_f·(ρ/ρ0 − 1), the explicit update sub-cycled under its stability limit,
//!   boundary pores (fixed pressure, fixed flux; impermeable otherwise).
//! - [`pressure_forces`]: pore pressure on the elements bounding each pore.
//! - [`coupling`]: the `pore_flow` stage's settings and the model-level calls that switch it
//!   on, set its boundaries and read its state (the pass is `effects/pore_flow/cpu/mod.rs`).
//! - [`fluid_temperature`]: with the heat field on, each pore's fluid has a temperature: it enters the
//!   equation of state (thermal expansion of the fluid), is carried by the flow (upwind
//!   advection) and exchanged with the elements at the pore's corners.

pub mod boundary;
pub mod coupling;
pub mod delaunay;
pub mod flow;
pub mod fluid_temperature;
pub mod geometry;
pub mod network;
pub mod pressure_forces;
pub mod stiffness;

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;

pub use boundary::{BoundaryKind, PoreBoundary, PoreRegion};
pub use coupling::{PoreFlowPlan, PoreSettings};
pub use flow::PoreFlow;
pub use fluid_temperature::FluidHeat;
pub use network::PoreNetwork;

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The pore fluid and how the network treats it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fluid {
    /// Bulk modulus K_f (Pa) of the equation of state p = K_f·(ρ/ρ0 − 1).
    pub bulk_modulus: f64,
    /// Reference density ρ0 (kg/m³), at zero (gauge) pressure.
    pub density: f64,
    /// Dynamic viscosity μ (Pa·s).
    pub viscosity: f64,
    /// Factor on the conductance of a throat whose face has bonded edges (cement partly
    /// filling the passage); 1 = bonds do not narrow throats. A broken bond removes it.
    pub cement_factor: f64,
    /// Smallest aperture of a crack (a broken bond), as a fraction of the mean radius of the
    /// throat's elements; the crack adds w³·b/(12 μ L) to its throat.
    pub crack_aperture: f64,
    /// Most flow sub-steps per mechanical step before the guard stops the run.
    pub max_substeps: u32,
    /// The network is rebuilt (fluid carried over) once an element has moved this fraction
    /// of the mean radius since the last build.
    pub rebuild_drift: f64,
    /// Thermal properties of the fluid (used when the heat field is on). Not in the fluid's
    /// own encoding: checkpoints carry it in a section of its own, so that files written
    /// before it existed still load (with water's values).
    #[serde(skip)]
    pub heat: FluidHeat,
    /// Factor on the conductance of the throats of each material's elements, by material name
    /// (a throat takes the harmonic mean of its face's three corners' factors; a material not
    /// named has 1): a finer or more cemented layer without finer grains. Carried by
    /// checkpoints beside `heat`.
    #[serde(skip)]
    pub permeability: BTreeMap<String, f64>,
}

impl Default for Fluid {
    fn default() -> Self {
        Fluid {
            bulk_modulus: 2.2e9,
            density: 1000.0,
            viscosity: 1.0e-3,
            cement_factor: 1.0,
            crack_aperture: 0.01,
            max_substeps: 1000,
            rebuild_drift: 0.5,
            heat: FluidHeat::default(),
            permeability: BTreeMap::new(),
        }
    }
}

impl Fluid {
    /// Checks every property, naming the first bad one.
    pub fn check(&self) -> crate::Result<()> {
        use crate::error::check_positive;
        check_positive("fluid bulk_modulus", self.bulk_modulus, false)?;
        check_positive("fluid density", self.density, false)?;
        check_positive("fluid viscosity", self.viscosity, false)?;
        check_positive("fluid cement_factor", self.cement_factor, true)?;
        check_positive("fluid crack_aperture", self.crack_aperture, true)?;
        check_positive("fluid rebuild_drift", self.rebuild_drift, false)?;
        self.heat.check()?;
        for (name, &f) in &self.permeability {
            if !(f.is_finite() && f > 0.0) {
                return Err(crate::Error::InvalidScene(format!(
                    "the permeability factor of material `{name}` is {f}: it must be a finite number > 0 (1 leaves \
                     its throats as the grains make them; 0.01 makes them a hundred times tighter)"
                )));
            }
        }
        let most = crate::physics::timestep::MAX_SUBSTEPS;
        if self.max_substeps == 0 || self.max_substeps > most {
            return Err(crate::Error::InvalidParameter {
                name: "fluid max_substeps",
                value: f64::from(self.max_substeps),
                reason: format!("must be 1 to {most}"),
            });
        }
        Ok(())
    }
}
