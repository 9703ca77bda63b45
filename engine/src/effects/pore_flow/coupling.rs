//! The `pore_flow` stage: pore density flow coupled into the time step.
//!
//! A scene switches it on ([`Model::enable_pore_flow`]); the network is then built from the
//! packing as it is, every pore at ρ0 (zero gauge pressure), and lives in
//! [`Model::pores`]. Each mechanical step (`effects/pore_flow/cpu/mod.rs`, between the wall
//! forces and the integration) follows the elements — the pore volumes, centres and throat
//! conductances from the current positions and bonds, the network rebuilt with its fluid
//! carried over once an element has drifted `rebuild_drift` × the mean radius — advances
//! the fluid by dt in sub-steps under its stable flow step (the guard stops the run naming
//! the pore when that needs more than `max_substeps`), and adds each pore's pressure to the
//! forces on the elements at its corners ([`super::pressure_forces`]). Nothing of it exists
//! in a scene that does not enable it: no network, no pass, no branch in the fused core.

use super::flow::{BoundaryKind, PoreBoundary, PoreFlow, PoreRegion};
use super::pressure_forces::add_pressure_forces;
use super::Fluid;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::physics::Vec3;

/// What a scene asks of the pore fluid (part of [`crate::model::Settings`]).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct PoreSettings {
    pub enabled: bool,
    pub fluid: Fluid,
    /// Boundary regions, in order (the last that holds a pore wins); pores in none are
    /// sealed (impermeable).
    pub boundaries: Vec<PoreBoundary>,
}

/// What a plan with the `pore_flow` stage runs (for the plan's words and lane account).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoreFlowPlan {
    pub pores: usize,
    pub throats: usize,
    /// Tetrahedra of the network (a pore is one or a few) and the elements at their corners.
    pub tets: usize,
    pub elements: usize,
    pub bulk_modulus: f64,
    pub density: f64,
    pub viscosity: f64,
    pub max_substeps: u32,
    pub fixed_pressure_regions: usize,
    pub flux_regions: usize,
    /// The heat field is on too: each pore's fluid has a temperature (in the equation of
    /// state, carried by the flow, exchanged with the grains; [`super::fluid_temperature`]).
    pub thermal: bool,
    /// The fluid's thermal properties (used when `thermal`).
    pub heat: super::FluidHeat,
}

impl PoreFlowPlan {
    /// The plan's pore flow, when the scene enabled it.
    pub fn of(m: &Model) -> Option<Self> {
        let s = &m.settings.pores;
        let f = m.pores.as_ref().filter(|_| s.enabled)?;
        let count = |want: fn(&BoundaryKind) -> bool| s.boundaries.iter().filter(|b| want(&b.kind)).count();
        Some(PoreFlowPlan {
            pores: f.network.pore_count(),
            throats: f.network.throats.len(),
            tets: f.network.tri.tets.len(),
            elements: m.len(),
            bulk_modulus: s.fluid.bulk_modulus,
            density: s.fluid.density,
            viscosity: s.fluid.viscosity,
            max_substeps: s.fluid.max_substeps,
            fixed_pressure_regions: count(|k| matches!(k, BoundaryKind::Pressure(_))),
            flux_regions: count(|k| matches!(k, BoundaryKind::Flux(_))),
            thermal: m.settings.heat.enabled,
            heat: s.fluid.heat,
        })
    }

    /// The stage's lanes: per pore (mass, pressure, volume, centre, region, source), per
    /// throat (conductance, opening, flow, the two pores), per element (its row of corners).
    pub fn lanes(&self) -> Vec<&'static str> {
        vec![
            if self.thermal {
                "pore: mass, pressure, volume, centre, region, source, temperature"
            } else {
                "pore: mass, pressure, volume, centre, region, source"
            },
            "throat: a, b, conductance, opening, flow",
            "element: corners",
        ]
    }

    /// Bytes of the network and fluid the stage holds (f64 values, u32 indices), about.
    pub fn bytes(&self) -> usize {
        let temperature = if self.thermal { 8 } else { 0 };
        self.pores * (8 * 4 + 24 + 4 + 8 + temperature) + self.throats * (4 * 4 + 8 * 3 + 1 + 1)
    }

    /// The stage's buffers on the GPU backend (effects/pore_flow/gpu/mod.rs, pore_heat.rs), by
    /// what they index.
    pub fn device_lanes(&self) -> Vec<&'static str> {
        vec![
            if self.thermal {
                "pore: tetrahedra row, volume, volume at upload, centre, excess mass, pressure, boundary, supplied \
                 mass, throat row, fluid supply, temperature, next temperature, temperature carry, excess mass carry, \
                 supplied heat"
            } else {
                "pore: tetrahedra row, volume, volume at upload, centre, excess mass, pressure, boundary, supplied \
                 mass, throat row"
            },
            if self.thermal {
                "tetrahedron: corners, pore, orientation, element corners, exchange conductance"
            } else {
                "tetrahedron: corners, pore, orientation, element corners"
            },
            "throat: row entries, throat (pores, face, bonds, factor), conductance, bonds across it",
            if self.thermal {
                "element: corner row, position at the build, temperature carry"
            } else {
                "element: corner row, position at the build"
            },
        ]
    }

    /// Bytes of the stage's buffers on the GPU backend (f32 values, u32 indices), about: the
    /// bonds across throats' faces (8 B each and a flag) not counted.
    pub fn device_bytes(&self) -> usize {
        let (pore, tet, element) = if self.thermal { (104, 60, 24) } else { (64, 44, 20) };
        self.pores * pore + self.tets * tet + self.throats * (8 + 32 + 4) + self.elements * element
    }
}

/// A permeability measured on the current network: steady Darcy flow between two opposite
/// faces of the packing held at a pressure difference (the Kirchhoff solution of the network's
/// own conductances), k = μ·Q·L/(A·Δp).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Permeability {
    /// k (m²).
    pub k: f64,
    /// The axis (0 = x, 1 = y, 2 = z) the flow ran along.
    pub axis: usize,
    /// Q (m³/s) at Δp = 1 Pa.
    pub flux: f64,
    /// L (m): between the inner edges of the two reservoir bands (each a tenth of the
    /// pores' extent along the axis).
    pub length: f64,
    /// A (m²): the cross-section of the element centres' bounding box.
    pub area: f64,
    /// The network's porosity: Σ pore volume / Σ tetrahedron volume.
    pub porosity: f64,
}

impl PoreFlow {
    /// Adds each pore's pressure to the forces on the elements at its corners.
    pub fn add_forces(&self, pos: &[Vec3], force: &mut [Vec3]) {
        add_pressure_forces(&self.network, &self.pressure, pos, force);
    }

    /// Each element's pore pressure: the mean over the tetrahedra it is a corner of, each
    /// weighted by its pore's volume share (its tetrahedron's volume); 0 for an element at no
    /// corner (fewer than four elements, or a duplicate position).
    pub fn element_pressure(&self, pos: &[Vec3]) -> Vec<f64> {
        self.network.element_mean(pos, &self.pressure, 0.0)
    }

    /// The network's porosity: Σ pore volume / Σ tetrahedron volume (the convex hull of the
    /// element centres).
    pub fn porosity(&self, pos: &[Vec3]) -> f64 {
        let net = &self.network;
        let hull: f64 =
            net.tri.tets.iter().map(|t| super::geometry::tet_volume(t.v.map(|j| pos[j as usize])).abs()).sum();
        net.volume.iter().sum::<f64>() / hull
    }

    /// The steady volumetric flow (m³/s) from `inlet` held at 1 Pa to `outlet` held at 0
    /// through a copy of the current network (every other pore sealed), and the mean centres
    /// of the two regions' pores (m): Darcy's law over any pair of regions,
    /// k = μ·Q·L/(A·Δp).
    pub fn darcy_flux(&self, inlet: PoreRegion, outlet: PoreRegion) -> Result<(f64, Vec3, Vec3)> {
        let mut f = self.clone();
        f.boundaries.clear();
        f.set_boundaries(vec![
            PoreBoundary { region: inlet, kind: BoundaryKind::Pressure(1.0), temperature: None },
            PoreBoundary { region: outlet, kind: BoundaryKind::Pressure(0.0), temperature: None },
        ])?;
        f.solve_steady(1e-12)?;
        let mean = |b: u32| {
            let (mut c, mut n) = (Vec3::zeros(), 0.0f64);
            for (p, r) in f.region.iter().enumerate() {
                if *r == b {
                    c += f.network.centre[p];
                    n += 1.0;
                }
            }
            c / n.max(1.0)
        };
        Ok((f.boundary_flow[0], mean(0), mean(1)))
    }

    /// Measures the permeability along `axis` on a copy of the current network: the pores in
    /// the first and last tenth of the pores' extent along it are reservoirs at 1 Pa and 0,
    /// everything else sealed, the steady state solved (conjugate gradients to 1e-12).
    pub fn permeability(&self, pos: &[Vec3], axis: usize) -> Result<Permeability> {
        if axis > 2 {
            return Err(Error::param("permeability axis", axis as f64, "must be 0 (x), 1 (y) or 2 (z)"));
        }
        let net = &self.network;
        let (lo, hi) = net.centre.iter().fold((f64::MAX, f64::MIN), |(a, b), c| (a.min(c[axis]), b.max(c[axis])));
        let band = 0.1 * (hi - lo);
        let big = 1e300;
        let slab = |from: f64, to: f64, p: f64| {
            let (mut a, mut b) = (Vec3::repeat(-big), Vec3::repeat(big));
            a[axis] = from;
            b[axis] = to;
            PoreBoundary::boxed(a, b, BoundaryKind::Pressure(p))
        };
        let mut f = self.clone();
        f.boundaries.clear();
        f.set_boundaries(vec![slab(-big, lo + band, 1.0), slab(hi - band, big, 0.0)])?;
        f.solve_steady(1e-12)?;
        let flux = f.boundary_flow[0];
        let (bl, bh) = pos.iter().fold((Vec3::repeat(f64::MAX), Vec3::repeat(f64::MIN)), |(a, b), x| {
            (a.zip_map(x, f64::min), b.zip_map(x, f64::max))
        });
        let ext = bh - bl;
        let area = ext[(axis + 1) % 3] * ext[(axis + 2) % 3];
        let length = hi - lo - 2.0 * band;
        Ok(Permeability {
            k: self.fluid.viscosity * flux * length / area,
            axis,
            flux,
            length,
            area,
            porosity: self.porosity(pos),
        })
    }
}

impl Model {
    /// Switches pore flow on: builds the pore network of the packing as it is now, every pore
    /// filled with the scene's fluid at ρ0 (zero gauge pressure), with the scene's boundary
    /// regions. Enabling again rebuilds it (the fluid starts afresh).
    pub fn enable_pore_flow(&mut self) -> Result<()> {
        if self.settings.planar.is_some() {
            return Err(Error::InvalidScene(
                "pore flow's pores are the tetrahedra between element centres in 3D; a 2D model's centres lie in \
                 one plane and enclose none (2D pore flow is not implemented): run the scene as a 3D slice"
                    .into(),
            ));
        }
        if self.len() < 4 {
            return Err(Error::InvalidScene(format!(
                "pore flow needs a packing of at least 4 elements (the pores are the tetrahedra of their centres); \
                 this model has {}: build the sample first",
                self.len()
            )));
        }
        let s = &self.settings.pores;
        let mut f = PoreFlow::new(self, s.fluid.clone())?;
        // Elements on one plane (or a line) make pores without volume, whose pressure would
        // turn non-finite at the first step: say so now.
        let vol = &f.network.volume;
        if vol.is_empty() || vol.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            let which = vol
                .iter()
                .position(|v| !(v.is_finite() && *v > 0.0))
                .map_or("no pore".into(), |p| format!("pore {p} has a fluid volume of {:e} m³", vol[p]));
            return Err(Error::InvalidScene(format!(
                "pore flow needs elements that enclose pores in 3D, but {which}: the elements' centres lie on one \
                 plane or coincide; build a packing several elements deep in every direction"
            )));
        }
        f.set_boundaries(s.boundaries.clone())?;
        self.pores = Some(Box::new(f));
        self.settings.pores.enabled = true;
        self.revision += 1;
        Ok(())
    }

    /// Switches pore flow off and drops the network and its fluid.
    pub fn disable_pore_flow(&mut self) {
        self.settings.pores.enabled = false;
        self.pores = None;
        self.revision += 1;
    }

    /// Sets the pore fluid (checked; the network's conductances follow at once).
    pub fn set_pore_fluid(&mut self, fluid: Fluid) -> Result<()> {
        fluid.check()?;
        if let Some(mut f) = self.pores.take() {
            // The masses stay; the pressures follow the new equation of state.
            f.fluid = fluid.clone();
            f.forget_stiffness();
            f.network.refresh(self, &fluid);
            f.update_pressure();
            self.pores = Some(f);
        }
        self.settings.pores.fluid = fluid;
        Ok(())
    }

    /// Adds a boundary region (after the others, so it wins where they overlap).
    pub fn add_pore_boundary(&mut self, region: PoreRegion, kind: BoundaryKind) -> Result<()> {
        self.add_pore_boundary_at(region, kind, None)
    }

    /// Adds a boundary region whose fluid comes at `temperature` (K; with the heat field on:
    /// a fixed-pressure region holds its pores at it, a flux region injects at it; `None`:
    /// at the pore's own temperature).
    pub fn add_pore_boundary_at(
        &mut self,
        region: PoreRegion,
        kind: BoundaryKind,
        temperature: Option<f64>,
    ) -> Result<()> {
        if let PoreRegion::Elements(ids) = &region {
            self.check_ids(ids)?;
        }
        let claims = matches!(region, PoreRegion::Cylinder { .. }) && kind != BoundaryKind::Impermeable;
        let mut all = self.settings.pores.boundaries.clone();
        all.push(PoreBoundary { region, kind, temperature });
        self.set_pore_boundaries(all, claims)
    }

    /// Removes every boundary region: the whole hull sealed again.
    pub fn clear_pore_boundaries(&mut self) -> Result<()> {
        let claimed = self.settings.pores.boundaries.iter().any(|b| matches!(b.region, PoreRegion::Cylinder { .. }));
        self.set_pore_boundaries(Vec::new(), claimed)
    }

    /// Sets the boundary regions; `reshape`: a borehole's open space joins or leaves the
    /// network (`PoreNetwork::build`), so it is rebuilt, the fluid carried over.
    fn set_pore_boundaries(&mut self, all: Vec<PoreBoundary>, reshape: bool) -> Result<()> {
        let Some(mut f) = self.pores.take() else {
            self.settings.pores.boundaries = all;
            return Ok(());
        };
        let old = std::mem::replace(&mut self.settings.pores.boundaries, all.clone());
        let done = f.set_boundaries(all).and_then(|()| if reshape { f.rebuild(self) } else { Ok(()) });
        if done.is_err() {
            self.settings.pores.boundaries = old;
        }
        self.pores = Some(f);
        done
    }
}

impl PoreFlowPlan {
    /// The stage in the plan's words.
    pub fn words(&self) -> String {
        let mut w = format!(
            "pore_flow({} pores, {} throats; K_f = {:.3e} Pa, ρ0 = {} kg/m³, μ = {:.3e} Pa·s; {} fixed-pressure and {} \
             flux region(s), the rest sealed; sub-stepped under V/(K_f·Σg), at most {} per step",
            self.pores,
            self.throats,
            self.bulk_modulus,
            self.density,
            self.viscosity,
            self.fixed_pressure_regions,
            self.flux_regions,
            self.max_substeps
        );
        if self.thermal {
            let h = &self.heat;
            w.push_str(&format!(
                "; fluid temperature: in the equation of state (β_f = {:.3e} /K), advected upwind (c_f = {} \
                 J/(kg·K)), exchanged with the grains (Nu = {}, k_f = {} W/(m·K))",
                h.expansion, h.specific_heat, h.nusselt, h.conductivity
            ));
        }
        w.push(')');
        w
    }
}
