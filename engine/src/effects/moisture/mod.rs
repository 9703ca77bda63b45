//! The moisture field (paper 003 §3.3, issue 15 item 3): a water content on every element,
//! diffusing to its neighbours over the contact network (eq. 3) and evaporating at a free
//! surface, acting back on the mechanics through drying shrinkage (radius) and bond strength,
//! each as a table of the water content the script gives. The optional `moisture` stage: a
//! scene that does not enable it has no lane, no pass and no pipeline for it.
//!
//! The effect's folder: the pair law (`physics.rs`), the scene's settings (`settings.rs`) and
//! the lanes (`lanes.rs`), held together as its state in the model (`state.rs`,
//! `m.effects.moisture`), the CPU pass (`cpu.rs`) and the GPU kernel (`gpu.rs`, with
//! `shaders/moisture.wgsl`). This file holds what a plan takes from the
//! settings, the model-level calls that switch it on and write its lanes, and the field's terms
//! of the shared diffusion core ([`WaterExchange`]).

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod lanes;
pub mod physics;
pub mod settings;
pub mod state;

use crate::diffusion::{self, Exchange};
use crate::effects::moisture::lanes::{MoistureLanes, FIXED, FREE, SEALED};
use crate::effects::moisture::physics::{evaporation_conductance, pair_moisture_conductance, Table};
pub use crate::effects::moisture::settings::MoistureSettings;
use crate::error::{Error, Result};
use crate::materials::base_name;
use crate::model::Model;

/// What a plan with the `moisture` stage runs.
#[derive(Debug, Clone, PartialEq)]
pub struct MoisturePlan {
    pub every: u32,
    pub substeps: u32,
    pub bond_radius: f64,
    /// Radii follow the water content (the `radius0` lane).
    pub radius_table: Option<Table>,
    /// Bond strengths follow the water content.
    pub strength_table: Option<Table>,
    /// With a radius table and thermal expansion both on, the reference temperature T0: the
    /// radius is the product r0·f(ω)·(1 + α·(T − T0)), and this stage keeps the expansion's
    /// r0 (the radius at T0) at r0·f(ω), so that the conduction stage's r0·(1 + α·(T − T0))
    /// is the same product without knowing the table.
    pub expansion: Option<f64>,
}

impl MoisturePlan {
    /// The plan's moisture, when the scene enables it.
    pub fn of(m: &Model) -> Option<Self> {
        let s = &m.effects.moisture.settings;
        s.enabled.then(|| MoisturePlan {
            every: s.every.max(1),
            substeps: s.substeps.max(1),
            bond_radius: s.bond_radius,
            radius_table: s.radius_table.clone(),
            strength_table: s.strength_table.clone(),
            expansion: s
                .radius_table
                .as_ref()
                .and(crate::effects::conduction::ConductionPlan::of(m))
                .filter(|c| c.expansion)
                .map(|c| c.reference),
        })
    }

    /// Whether the field step runs after the step that starts at `step`.
    pub fn runs_after(&self, step: u64) -> bool {
        (step + 1).is_multiple_of(u64::from(self.every))
    }

    /// One forward-Euler sub-step (s).
    pub fn substep(&self, dt: f64) -> f64 {
        dt * f64::from(self.every) / f64::from(self.substeps)
    }

    /// The lanes a particle carries, in [`MoistureLanes`]' order.
    pub fn lanes(&self) -> Vec<&'static str> {
        let mut l = vec!["water", "diffusivity", "transfer", "ambient", "conductance", "mode"];
        if self.radius_table.is_some() {
            l.push("radius0");
        }
        l
    }

    /// Bytes per particle of [`lanes`](Self::lanes) on the CPU (f64, the mode a byte).
    pub fn bytes_per_particle(&self) -> usize {
        8 * (self.lanes().len() - 1) + 1
    }
}

/// Water's terms of the diffusion core: evaporation towards the ambient water content, and
/// the contact-area conductance of eq. 3. Capacity: the element's mass.
pub struct WaterExchange<'a> {
    pub radius: &'a [f64],
    pub diffusivity: &'a [f64],
    pub transfer: &'a [f64],
    pub ambient: &'a [f64],
    pub bond_radius: f64,
}

impl<'a> WaterExchange<'a> {
    pub fn new(radius: &'a [f64], w: &'a MoistureLanes, bond_radius: f64) -> Self {
        WaterExchange { radius, diffusivity: &w.diffusivity, transfer: &w.transfer, ambient: &w.ambient, bond_radius }
    }
}

impl Exchange for WaterExchange<'_> {
    #[inline(always)]
    fn own(&self, i: usize, u: f64) -> (f64, f64) {
        let e = evaporation_conductance(self.transfer[i], self.radius[i]);
        (e * (self.ambient[i] - u), e)
    }

    #[inline(always)]
    fn pair(&self, i: usize, j: usize, dist: f64, bonded: bool) -> f64 {
        let (a, r) = (self.diffusivity, self.radius);
        pair_moisture_conductance(a[i], a[j], r[i], r[j], dist, bonded, self.bond_radius)
    }
}

/// How an element takes part in moisture diffusion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WaterMode {
    /// Exchanges water with its neighbours.
    Free,
    /// Held at its water content (or at the one given): a boundary at a fixed water content.
    Fixed(Option<f64>),
    /// Exchanges no water with any neighbour (evaporation, when set, still dries it).
    Sealed,
}

impl MoisturePlan {
    /// The stage in the plan's words.
    pub fn words(&self) -> String {
        let mut s = format!("moisture(forward euler every {} step(s) in {} sub-step(s)", self.every, self.substeps);
        if self.radius_table.is_some() {
            s.push_str(", drying shrinkage");
        }
        if self.expansion.is_some() {
            s.push_str(" × thermal expansion");
        }
        if self.strength_table.is_some() {
            s.push_str(", bond strength by water content");
        }
        s.push(')');
        s
    }
}

impl Model {
    /// Switches moisture on and allocates its lanes (every element at the initial water
    /// content, with its material's diffusivity).
    pub fn enable_moisture(&mut self) {
        self.effects.moisture.settings.enabled = true;
        self.fit_moisture();
    }

    /// Allocates the moisture lanes the settings call for, for every element (a no-op once
    /// they are); `radius0` only with a radius table.
    pub fn fit_moisture(&mut self) {
        let s = &self.effects.moisture.settings;
        if !s.enabled {
            return;
        }
        let n = self.len();
        let shrink = s.radius_table.is_some();
        let initial = s.initial;
        let w = &mut self.effects.moisture.lanes;
        if w.water.len() != n {
            *w = MoistureLanes {
                water: vec![initial; n],
                diffusivity: vec![0.0; n],
                transfer: vec![0.0; n],
                ambient: vec![0.0; n],
                conductance: vec![0.0; n],
                mode: vec![FREE; n],
                radius0: Vec::new(),
            };
            for i in 0..n {
                self.init_moisture(i);
            }
        }
        if shrink && self.effects.moisture.lanes.radius0.len() != n {
            // With thermal expansion on, the table's r0 is the expansion's: the radius at the
            // reference temperature (so the two factors multiply one r0, not each other's).
            let th = &self.particles.thermal.radius0;
            let r0 = if th.len() == n { th } else { &self.particles.radius };
            self.effects.moisture.lanes.radius0 = r0.clone();
        }
    }

    /// Sets element `i`'s diffusivity from its material.
    pub(crate) fn init_moisture(&mut self, i: usize) {
        let name = &self.materials[self.particles.material[i] as usize].name;
        // A clone made by a per-element write (`rock~3`) has its base material's diffusivity.
        let a = self.effects.moisture.settings.diffusivity(name, base_name(name));
        if let Some(d) = self.effects.moisture.lanes.diffusivity.get_mut(i) {
            *d = a;
        }
    }

    /// The moisture lanes, or an error saying moisture is off.
    pub fn moisture_lanes(&mut self, to: &str) -> Result<&mut MoistureLanes> {
        if !self.effects.moisture.settings.enabled {
            return Err(Error::InvalidScene(format!("moisture is off: call d.enable(\"moisture\") before you {to}")));
        }
        self.fit_moisture();
        Ok(&mut self.effects.moisture.lanes)
    }

    /// Sets a material's moisture diffusivity α_w (kg/(m²·s)), and its elements'.
    pub fn set_moisture_material(&mut self, material: &str, diffusivity: f64) -> Result<()> {
        let k = self.material_index(material)?;
        check_rate(&format!("moisture diffusivity of material `{material}`"), diffusivity)?;
        self.effects.moisture.settings.materials.insert(material.to_string(), diffusivity);
        self.fit_moisture();
        for i in 0..self.len() {
            let mi = self.particles.material[i];
            if mi == k || base_name(&self.materials[mi as usize].name) == material {
                self.init_moisture(i);
            }
        }
        Ok(())
    }

    /// Overrides the diffusivity of the elements of group `group` (moisture must be on).
    pub fn set_moisture_group(&mut self, group: &str, diffusivity: f64) -> Result<()> {
        check_rate(&format!("moisture diffusivity of group `{group}`"), diffusivity)?;
        let ids = self.groups.get(group)?.to_vec();
        let w = self.moisture_lanes("set the diffusivity of a group")?;
        for &i in &ids {
            w.diffusivity[i as usize] = diffusivity;
        }
        Ok(())
    }

    /// Holds group `group` at its water content (`Some(w)`: at `w`), seals it, or frees it.
    pub fn set_water_mode(&mut self, group: &str, mode: WaterMode) -> Result<()> {
        if let WaterMode::Fixed(Some(v)) = mode {
            check_water(&format!("fixed water content of group `{group}`"), v)?;
        }
        let ids = self.groups.get(group)?.to_vec();
        let w = self.moisture_lanes("set a fixed-water or sealed group")?;
        for &i in &ids {
            let i = i as usize;
            w.mode[i] = match mode {
                WaterMode::Free => FREE,
                WaterMode::Fixed(v) => {
                    if let Some(v) = v {
                        w.water[i] = v;
                    }
                    FIXED
                }
                WaterMode::Sealed => SEALED,
            };
        }
        Ok(())
    }

    /// Evaporation from the elements of group `group`: each loses χ·π·r²·(ω − ω_a) kg/s
    /// (`transfer` χ in kg/(m²·s), 0 stops it; `ambient` ω_a the air's water content).
    pub fn set_evaporation(&mut self, group: &str, transfer: f64, ambient: f64) -> Result<()> {
        check_rate(&format!("evaporation of group `{group}`: transfer coefficient"), transfer)?;
        check_water(&format!("evaporation of group `{group}`: ambient water content"), ambient)?;
        let ids = self.groups.get(group)?.to_vec();
        if ids.is_empty() {
            return Err(Error::InvalidScene(format!("evaporation: group `{group}` is empty")));
        }
        let w = self.moisture_lanes("set evaporation")?;
        for &i in &ids {
            w.transfer[i as usize] = transfer;
            w.ambient[i as usize] = ambient;
        }
        Ok(())
    }

    /// Writes every element's water content (moisture must be on).
    pub fn set_water(&mut self, values: &[f64]) -> Result<()> {
        let n = self.len();
        if values.len() != n {
            return Err(Error::InvalidScene(format!(
                "water: {} values for {n} elements; give one per element",
                values.len()
            )));
        }
        if let Some(k) = values.iter().position(|v| !v.is_finite() || *v < 0.0) {
            return Err(Error::InvalidScene(format!(
                "water content of element {k} is {}: give a finite value ≥ 0",
                values[k]
            )));
        }
        self.moisture_lanes("set water contents")?.water.copy_from_slice(values);
        Ok(())
    }

    /// Sets the drying-shrinkage table, r = r0·f(ω) (`None` removes it; radii stay as they are).
    /// The radii at the time it is set are each element's r0.
    pub fn set_radius_table(&mut self, points: Option<Vec<(f64, f64)>>) -> Result<()> {
        let table =
            points.map(|p| Table::new(p, "radius table", 0.0, f64::MAX)).transpose().map_err(Error::InvalidScene)?;
        self.effects.moisture.settings.radius_table = table;
        self.effects.moisture.lanes.radius0.clear();
        self.fit_moisture();
        self.revision += 1;
        Ok(())
    }

    /// Sets the bond-strength table, a bond's share s(ω) ∈ (0, 1] of its pair's strength at the
    /// pair's mean water content (`None` removes it; bonds keep their shares).
    pub fn set_strength_table(&mut self, points: Option<Vec<(f64, f64)>>) -> Result<()> {
        let table =
            points.map(|p| Table::new(p, "strength table", 0.0, 1.0)).transpose().map_err(Error::InvalidScene)?;
        self.effects.moisture.settings.strength_table = table;
        self.revision += 1;
        Ok(())
    }

    /// Total water Σ m_i·ω_i (kg); 0 with moisture off.
    pub fn total_water(&self) -> f64 {
        let w = &self.effects.moisture.lanes.water;
        if w.len() != self.len() {
            return 0.0;
        }
        w.iter().zip(&self.particles.mass).map(|(w, m)| w * m).sum()
    }

    /// The moisture stage's checks before and during a run: every free element has mass, and the forward-Euler sub-step is below m_i/ΣG_i at every element (rows must be built;
    /// without rows nothing more is checked). The error names the element, its limit and the fix.
    pub fn check_moisture(&self) -> Result<()> {
        let Some(plan) = MoisturePlan::of(self) else { return Ok(()) };
        let w = &self.effects.moisture.lanes;
        let n = self.len();
        if w.water.len() != n {
            return Ok(());
        }
        let c = &self.contacts;
        if c.row_start.len() != n + 1 || c.stale {
            return Ok(());
        }
        let dt = plan.substep(self.clock.dt);
        let p = &self.particles;
        let x = WaterExchange::new(&p.radius, w, plan.bond_radius);
        if let Some((i, g, limit)) =
            diffusion::unstable_element(&x, &p.pos, &self.separations(), c, &w.water, &p.mass, &w.mode, dt)
        {
            let need = (f64::from(plan.every) * self.clock.dt / limit).floor() as u64 + 1;
            return Err(Error::InvalidScene(format!(
                "moisture diffusion is unstable at element {i} (material `{}`): its mass m = {:.3e} kg and moisture \
                 conductance ΣG = {g:.3e} kg/s (with evaporation) allow a field step below m/ΣG = {limit:.3e} s \
                 (forward Euler), but the field step is {dt:.3e} s ({} mechanical steps of {:.3e} s in {} sub-steps). \
                 Fix: set d.moisture_substeps to {need} or more, or a smaller d.moisture_every",
                self.materials[p.material[i] as usize].name, p.mass[i], plan.every, self.clock.dt, plan.substeps
            )));
        }
        Ok(())
    }
}

fn check_rate(what: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidScene(format!("{what} = {v} must be a finite number ≥ 0 (kg/(m²·s))")))
    }
}

fn check_water(what: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidScene(format!("{what} = {v} must be a finite water content ≥ 0 (kg/kg)")))
    }
}
