//! Heat conduction (paper 003 §3.3): a temperature on every element, exchanged with its
//! neighbours over the contact network, with sources, fixed and insulated groups, and acting
//! back on the mechanics by thermal expansion of the radii. The optional `conduction` stage: a
//! scene that does not enable heat has no lane, no pass and no pipeline for it.
//!
//! The effect's folder: the pair conductance (`physics.rs`), the scene's settings
//! (`settings.rs`, part of [`crate::model::Settings`]), the thermal lanes (`lanes.rs`), the CPU
//! pass (`cpu.rs`) and the GPU kernel (`gpu.rs`, with `shaders/conduction.wgsl`). This file holds
//! what a plan takes from the settings and the model-level calls that switch heat on and write
//! its lanes.

pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod lanes;
pub mod physics;
pub mod settings;

use crate::effects::conduction::lanes::{ThermalLanes, FIXED, FREE, INSULATED};
use crate::effects::conduction::physics::pair_conductance;
pub use crate::effects::conduction::settings::{HeatSettings, ThermalProps};
use crate::error::{Error, Result};
use crate::materials::base_name;
use crate::model::Model;

/// What a plan with the `conduction` stage runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConductionPlan {
    pub reference: f64,
    pub every: u32,
    pub substeps: u32,
    pub bond_radius: f64,
    /// Some element has α ≠ 0: radii follow temperature (the `expansion` and `radius0` lanes).
    pub expansion: bool,
    /// The ledger's heat is fed into temperature (the `fed` lane).
    pub dissipation: bool,
}

impl ConductionPlan {
    /// The plan's conduction, when the scene enables heat.
    pub fn of(m: &Model) -> Option<Self> {
        let h = &m.settings.heat;
        h.enabled.then(|| ConductionPlan {
            reference: h.reference,
            every: h.every.max(1),
            substeps: h.substeps.max(1),
            bond_radius: h.bond_radius,
            expansion: !m.particles.thermal.expansion.is_empty() || h.materials.values().any(|p| p.expansion != 0.0),
            dissipation: h.dissipation,
        })
    }

    /// Whether conduction runs after the step that starts at `step`.
    pub fn runs_after(&self, step: u64) -> bool {
        (step + 1).is_multiple_of(u64::from(self.every))
    }

    /// One forward-Euler sub-step (s).
    pub fn substep(&self, dt: f64) -> f64 {
        dt * f64::from(self.every) / f64::from(self.substeps)
    }

    /// The lanes a particle carries, in [`ThermalLanes`]' order.
    pub fn lanes(&self) -> Vec<&'static str> {
        let mut l = vec!["temperature", "capacity", "conductivity", "source", "conductance", "thermal_mode"];
        if self.expansion {
            l.extend(["expansion", "radius0"]);
        }
        if self.dissipation {
            l.push("fed");
        }
        l
    }

    /// Bytes per particle of [`lanes`](Self::lanes) on the CPU (f64, the mode a byte).
    pub fn bytes_per_particle(&self) -> usize {
        8 * (self.lanes().len() - 1) + 1
    }
}

impl ConductionPlan {
    /// The stage in the plan's words.
    pub fn words(&self) -> String {
        let mut w = format!("conduction(forward euler every {} step(s) in {} sub-step(s)", self.every, self.substeps);
        if self.expansion {
            w.push_str(", thermal expansion");
        }
        if self.dissipation {
            w.push_str(", dissipated heat fed in");
        }
        w.push(')');
        w
    }
}

impl Model {
    /// Switches heat conduction on and allocates its lanes (every element at the reference
    /// temperature, with its material's properties).
    pub fn enable_heat(&mut self) {
        self.settings.heat.enabled = true;
        self.fit_thermal();
    }

    /// Allocates the thermal lanes the settings call for, for every element (a no-op once
    /// they are); the expansion lanes only when some element expands.
    pub fn fit_thermal(&mut self) {
        let Some(plan) = ConductionPlan::of(self) else { return };
        let n = self.len();
        let t = &self.particles.thermal;
        let fresh = t.temperature.len() != n;
        if fresh {
            let th = &mut self.particles.thermal;
            th.temperature = vec![plan.reference; n];
            th.capacity = vec![0.0; n];
            th.conductivity = vec![0.0; n];
            th.source = vec![0.0; n];
            th.conductance = vec![0.0; n];
            th.mode = vec![FREE; n];
        }
        if plan.expansion && self.particles.thermal.expansion.len() != n {
            self.particles.thermal.expansion = vec![0.0; n];
            self.particles.thermal.radius0 = self.particles.radius.clone();
        }
        if plan.dissipation && self.particles.thermal.fed.len() != n {
            // Heat booked before feeding was switched on stays out of the temperature.
            self.particles.thermal.fed = (0..n).map(|i| self.booked_heat(i)).collect();
        }
        if fresh {
            for i in 0..n {
                self.init_thermal(i);
            }
        }
    }

    /// Sets element `i`'s capacity, conductivity and expansion from its material.
    pub(crate) fn init_thermal(&mut self, i: usize) {
        let name = &self.materials[self.particles.material[i] as usize].name;
        // A clone made by a per-element write (`rock~3`) has its base material's properties.
        let heat = &self.settings.heat.materials;
        let p = heat.get(name).or_else(|| heat.get(base_name(name))).copied().unwrap_or_default();
        let n = self.particles.len();
        let mass = self.particles.mass[i];
        let th = &mut self.particles.thermal;
        if th.temperature.len() != n {
            return;
        }
        th.capacity[i] = mass * p.specific_heat;
        th.conductivity[i] = p.conductivity;
        if !th.expansion.is_empty() {
            th.expansion[i] = p.expansion;
        }
    }

    /// The heat the ledger has booked on element `i` (J), wall work excluded.
    pub fn booked_heat(&self, i: usize) -> f64 {
        let h = &self.particles.heat;
        [&h.damping, &h.contact_damping, &h.friction, &h.breakage]
            .iter()
            .map(|l| l.get(i).copied().unwrap_or(0.0))
            .sum()
    }

    /// Sets a material's thermal properties (and those of its elements, when the lanes exist).
    pub fn set_thermal_material(&mut self, material: &str, props: ThermalProps) -> Result<()> {
        let k = self.material_index(material)?;
        props.validate(&format!("thermal properties of material `{material}`"))?;
        self.settings.heat.materials.insert(material.to_string(), props);
        self.fit_thermal();
        for i in 0..self.len() {
            let mi = self.particles.material[i];
            if mi == k || base_name(&self.materials[mi as usize].name) == material {
                self.init_thermal(i);
            }
        }
        Ok(())
    }

    /// Overrides the thermal properties the update names for the elements of group `group`
    /// (heat must be on); the others keep theirs.
    pub fn set_thermal_group(&mut self, group: &str, update: ThermalUpdate) -> Result<()> {
        let check = ThermalProps {
            conductivity: update.conductivity.unwrap_or(0.0),
            specific_heat: update.specific_heat.unwrap_or(0.0),
            expansion: update.expansion.unwrap_or(0.0),
        };
        check.validate(&format!("thermal properties of group `{group}`"))?;
        let ids = self.groups.get(group)?.to_vec();
        self.thermal_lanes("set the thermal properties of a group")?;
        if update.expansion.is_some_and(|a| a != 0.0) && self.particles.thermal.expansion.is_empty() {
            let n = self.len();
            self.particles.thermal.expansion = vec![0.0; n];
            self.particles.thermal.radius0 = self.particles.radius.clone();
            // The plan gains the expansion lanes.
            self.touch_plan();
        }
        let p = &mut self.particles;
        let th = &mut p.thermal;
        for &i in &ids {
            let i = i as usize;
            if let Some(c) = update.specific_heat {
                th.capacity[i] = p.mass[i] * c;
            }
            if let Some(k) = update.conductivity {
                th.conductivity[i] = k;
            }
            if let (Some(a), false) = (update.expansion, th.expansion.is_empty()) {
                th.expansion[i] = a;
            }
        }
        Ok(())
    }

    /// Holds group `group` at its current temperature (`Some(t)`: at `t`), or frees it.
    pub fn set_thermal_mode(&mut self, group: &str, mode: ThermalMode) -> Result<()> {
        let ids = self.groups.get(group)?.to_vec();
        let th = self.thermal_lanes("set a fixed-temperature or insulated group")?;
        for &i in &ids {
            let i = i as usize;
            th.mode[i] = match mode {
                ThermalMode::Free => FREE,
                ThermalMode::Fixed(t) => {
                    if let Some(t) = t {
                        th.temperature[i] = t;
                    }
                    FIXED
                }
                ThermalMode::Insulated => INSULATED,
            };
        }
        Ok(())
    }

    /// A heat source: `power` watts shared equally among the elements of `group` (replaces an
    /// earlier source on them; 0 removes it).
    pub fn set_heat_source(&mut self, group: &str, power: f64) -> Result<()> {
        if !power.is_finite() {
            return Err(Error::InvalidScene(format!("heat source of group `{group}`: power {power} W is not finite")));
        }
        let ids = self.groups.get(group)?.to_vec();
        if ids.is_empty() {
            return Err(Error::InvalidScene(format!("heat source: group `{group}` is empty")));
        }
        let th = self.thermal_lanes("add a heat source")?;
        let each = power / ids.len() as f64;
        for &i in &ids {
            th.source[i as usize] = each;
        }
        Ok(())
    }

    /// The thermal lanes, or an error saying heat is off.
    pub fn thermal_lanes(&mut self, to: &str) -> Result<&mut ThermalLanes> {
        if !self.settings.heat.enabled {
            return Err(Error::InvalidScene(format!("heat is off: call d.enable(\"heat\") before you {to}")));
        }
        self.fit_thermal();
        Ok(&mut self.particles.thermal)
    }

    /// Writes every element's temperature (heat must be on).
    pub fn set_temperatures(&mut self, t: &[f64]) -> Result<()> {
        let n = self.len();
        if t.len() != n {
            return Err(Error::InvalidScene(format!(
                "temperature: {} values for {n} elements; give one per element",
                t.len()
            )));
        }
        if let Some(k) = t.iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidScene(format!("temperature of element {k} is {}: give a finite value", t[k])));
        }
        if let Some(k) = t.iter().position(|&v| v < 0.0) {
            return Err(Error::InvalidScene(format!(
                "temperature of element {k} is {} K, below absolute zero: temperatures are in kelvin (20 °C is \
                 293.15 K)",
                t[k]
            )));
        }
        self.thermal_lanes("set temperatures")?.temperature.copy_from_slice(t);
        Ok(())
    }

    /// Invalidates a prepared plan (lanes that change the plan were added).
    fn touch_plan(&mut self) {
        self.revision += 1;
    }

    /// The forward-Euler stability check of conduction: every free element needs
    /// Δt_f < C_i/ΣH_i, with ΣH_i from the current contacts (rows must be built; without rows
    /// nothing is checked). The error names the element, its limit and the fix.
    pub fn check_conduction(&self) -> Result<()> {
        let Some(plan) = ConductionPlan::of(self) else { return Ok(()) };
        let th = &self.particles.thermal;
        let n = self.len();
        if th.temperature.len() != n {
            return Ok(());
        }
        let dt = plan.substep(self.clock.dt);
        let (p, c, sep) = (&self.particles, &self.contacts, self.separations());
        let rows = c.row_start.len() == n + 1 && !c.stale;
        for i in 0..n {
            if th.mode[i] == FIXED {
                continue;
            }
            let name = || &self.materials[p.material[i] as usize].name;
            if th.capacity[i] <= 0.0 {
                return Err(Error::InvalidScene(format!(
                    "heat conduction: element {i} (material `{}`) has no heat capacity (C = m·c = {}): set its \
                     specific heat with d.thermal(\"{}\", #{{specific_heat: …}}) or fix its temperature",
                    name(),
                    th.capacity[i],
                    name()
                )));
            }
            if !rows || th.mode[i] == INSULATED {
                continue;
            }
            let mut g = 0.0;
            for k in c.row(i) {
                let j = c.other[k] as usize;
                if th.mode[j] == INSULATED {
                    continue;
                }
                let d = sep.between(&p.pos, i, j).norm();
                g += pair_conductance(
                    th.conductivity[i],
                    th.conductivity[j],
                    p.radius[i],
                    p.radius[j],
                    d,
                    c.state[k].bonded,
                    plan.bond_radius,
                );
            }
            let limit = th.capacity[i] / g;
            if g > 0.0 && dt >= limit {
                let need = (f64::from(plan.every) * self.clock.dt / limit).floor() as u64 + 1;
                return Err(Error::InvalidScene(format!(
                    "heat conduction is unstable at element {i} (material `{}`): its capacity C = {:.3e} J/K and \
                     conductance ΣH = {g:.3e} W/K allow a field step below C/ΣH = {limit:.3e} s (forward Euler), but \
                     the field step is {dt:.3e} s ({} mechanical steps of {:.3e} s in {} sub-steps). Fix: set \
                     d.heat_substeps to {need} or more, or a smaller d.heat_every",
                    name(),
                    th.capacity[i],
                    plan.every,
                    self.clock.dt,
                    plan.substeps
                )));
            }
        }
        Ok(())
    }
}

/// Thermal properties to change, each when given.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ThermalUpdate {
    pub conductivity: Option<f64>,
    pub specific_heat: Option<f64>,
    pub expansion: Option<f64>,
}

impl ThermalUpdate {
    /// `base` with the given properties replaced.
    pub fn apply(&self, base: ThermalProps) -> ThermalProps {
        ThermalProps {
            conductivity: self.conductivity.unwrap_or(base.conductivity),
            specific_heat: self.specific_heat.unwrap_or(base.specific_heat),
            expansion: self.expansion.unwrap_or(base.expansion),
        }
    }
}

/// How an element takes part in conduction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ThermalMode {
    /// Exchanges heat with its neighbours.
    Free,
    /// Held at its temperature (or at the one given): a boundary at a fixed temperature.
    Fixed(Option<f64>),
    /// Exchanges no heat with any neighbour (an adiabatic element); sources still heat it.
    Insulated,
}
