//! The pore fluid: mass per pore, density ρ = m / V_p, pressure p = K_f·(ρ/ρ0 − 1) — with the
//! heat field on, p = K_f·(ρ/ρ0 − 1 + β_f·(T − T0)) ([`super::fluid_temperature`]) — and its explicit update.
//!
//! A throat carries the volumetric flow q = g·(p_a − p_b) (Poiseuille-type conductance g,
//! [`super::geometry::poiseuille`]) and so the mass ρ0·q from a to b; each pore sums its own
//! row of throats, so mass moves from one pore to another and is conserved to round-off.
//! With dm_i/dt = ρ0·Σ_j g_ij (p_j − p_i) and dp/dm = K_f/(ρ0 V_i), the pressures obey
//! dp_i/dt = (K_f / V_i)·Σ_j g_ij (p_j − p_i); forward Euler is stable for a step
//! h ≤ V_i / (K_f·Σ_j g_ij) at every pore (Gershgorin's bound on the spectrum, 2/λ_max ≥
//! that), the flow's own critical step. The mechanical step is divided into as many flow
//! sub-steps as that needs, up to the fluid's `max_substeps`, beyond which the guard stops
//! the run naming the pore.

pub use super::boundary::{BoundaryKind, PoreBoundary, PoreRegion};
use super::network::PoreNetwork;
use super::Fluid;
use crate::error::{Error, Instability, Result, Suggestion};
use crate::model::Model;
use crate::physics::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The fluid's spring on one element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FluidSpring {
    /// N/m, summed over the element's free pores.
    pub stiffness: f64,
    /// The pore that contributes most.
    pub pore: usize,
}

/// The element with the shortest critical step for the fluid and its contacts together.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StiffestElement {
    /// √2·√(m/(k_contacts + k_fluid)) (s).
    pub critical_dt: f64,
    pub element: usize,
    pub spring: FluidSpring,
    /// The element's own contact stiffness estimate (N/m).
    pub contacts: f64,
    /// The flow's critical step V_p/(K_f·Σg) on the same network (s).
    pub flow_dt: f64,
}

/// No boundary region holds this pore.
pub(crate) const FREE: u32 = u32::MAX;

/// Safety factor under the critical flow step.
pub const FLOW_SAFETY: f64 = 0.9;

/// Flow sub-steps of a mechanical step `dt` under the stable flow step `crit`:
/// ⌈dt / (FLOW_SAFETY · crit)⌉, at least 1 (1 when no pore is connected: `crit` infinite).
pub fn substeps_for(dt: f64, crit: f64) -> f64 {
    if crit.is_finite() {
        (dt / (FLOW_SAFETY * crit)).ceil().max(1.0)
    } else {
        1.0
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PoreFlow {
    pub fluid: Fluid,
    pub boundaries: Vec<PoreBoundary>,
    pub network: PoreNetwork,
    /// Fluid mass of each pore (kg).
    pub mass: Vec<f64>,
    /// Pressure of each pore (Pa, gauge), from its mass and volume.
    pub pressure: Vec<f64>,
    /// Boundary region of each pore, or none.
    pub region: Vec<u32>,
    /// Volumetric source of each pore (m³/s), from fixed-flux regions.
    pub source: Vec<f64>,
    /// Volumetric flow of each throat from its pore `a` to `b` (m³/s), last sub-step.
    pub flow: Vec<f64>,
    /// Volumetric rate each boundary region sends into the rest of the network (m³/s), last
    /// sub-step.
    pub boundary_flow: Vec<f64>,
    /// Mass the boundaries have added since the start (kg; negative when they drained).
    pub boundary_mass: f64,
    /// Flow sub-steps of the last mechanical step.
    pub substeps: u32,
    /// Network rebuilds since the start.
    pub rebuilds: u32,
    /// The stiffest element for the fluid and its contacts together, the stiffest of the
    /// estimates made each time the network was built (before anything can have blown up), for
    /// the guard's message ([`crate::effects::pore_flow::stiffness`]).
    #[serde(skip)]
    pub stiffest: Option<StiffestElement>,
    /// Whether `stiffest` has seen the network as last built.
    #[serde(skip)]
    estimated: bool,
    // What pore flow gained after checkpoint format 7's first pore section: kept out of this
    // struct's encoding and carried by a section of their own (`checkpoint::Section::PoreHeat`),
    // so that files written before them still load.
    /// Temperature of each pore's fluid (K); empty while the heat field is off.
    #[serde(skip)]
    pub temperature: Vec<f64>,
    /// Reference temperature T0 of the equation of state (the heat field's, K).
    #[serde(skip)]
    pub reference: f64,
    /// Mass each boundary region has added since the start (kg; negative where it drained).
    #[serde(skip)]
    pub region_mass: Vec<f64>,
    /// Heat each boundary region has added since the start (J): c_f·Δm·(T − T0) of the fluid
    /// it supplied or took, and the heat that holds its pores at its temperature.
    #[serde(skip)]
    pub region_heat: Vec<f64>,
    /// Sub-steps of the fluid–grain heat exchange in the last mechanical step.
    #[serde(skip)]
    pub exchange_substeps: u32,
}

impl PoreFlow {
    /// Fluid at zero pressure in every pore of the model's packing.
    pub fn new(m: &Model, fluid: Fluid) -> Result<Self> {
        fluid.check()?;
        let mut network = PoreNetwork::build(m)?;
        network.refresh(m, &fluid);
        let mass: Vec<f64> = network.volume.iter().map(|v| fluid.density * v).collect();
        let np = mass.len();
        let nt = network.throats.len();
        let mut f = PoreFlow {
            fluid,
            boundaries: Vec::new(),
            network,
            mass,
            pressure: vec![0.0; np],
            region: vec![FREE; np],
            source: vec![0.0; np],
            flow: vec![0.0; nt],
            boundary_flow: Vec::new(),
            boundary_mass: 0.0,
            substeps: 0,
            rebuilds: 0,
            stiffest: None,
            estimated: false,
            temperature: Vec::new(),
            reference: 0.0,
            region_mass: Vec::new(),
            region_heat: Vec::new(),
            exchange_substeps: 0,
        };
        f.update_pressure();
        Ok(f)
    }

    /// Sets the boundary regions (replacing any) and applies them.
    pub fn set_boundaries(&mut self, boundaries: Vec<PoreBoundary>) -> Result<()> {
        for b in &boundaries {
            let finite = |v: &Vec3| v.iter().all(|x| x.is_finite());
            let ok = match &b.region {
                PoreRegion::Box { lo, hi } => finite(lo) && finite(hi),
                PoreRegion::Point(x) => finite(x),
                PoreRegion::Elements(_) => true,
                PoreRegion::Cylinder { center, axis, radius } => {
                    finite(center)
                        && finite(axis)
                        && (axis.norm() - 1.0).abs() < 1e-9
                        && *radius > 0.0
                        && radius.is_finite()
                }
            };
            if !ok {
                return Err(Error::InvalidScene(
                    "a pore boundary region needs finite corners and points (and a cylinder a unit axis and a radius above 0)".into(),
                ));
            }
            if let BoundaryKind::Pressure(p) | BoundaryKind::Flux(p) = b.kind {
                if !p.is_finite() {
                    return Err(Error::param("pore boundary value", p, "must be a finite number"));
                }
            }
            if let Some(t) = b.temperature {
                if !t.is_finite() {
                    return Err(Error::param("pore boundary temperature", t, "must be a finite number (K)"));
                }
            }
        }
        // Regions kept (a region added after the others) keep their totals.
        self.region_mass.resize(boundaries.len(), 0.0);
        self.region_heat.resize(boundaries.len(), 0.0);
        self.boundaries = boundaries;
        self.boundary_mass += self.resolve_boundaries();
        Ok(())
    }

    /// Finds each pore's region and source; returns the mass the fixed pressures added.
    fn resolve_boundaries(&mut self) -> f64 {
        let net = &self.network;
        let np = net.pore_count();
        self.region = vec![FREE; np];
        self.source = vec![0.0; np];
        for (b, bc) in self.boundaries.iter().enumerate() {
            let id = if bc.kind == BoundaryKind::Impermeable { FREE } else { b as u32 };
            match &bc.region {
                PoreRegion::Box { .. } | PoreRegion::Cylinder { .. } => {
                    for p in 0..np {
                        if bc.region.contains(&net.centre[p]) == Some(true) {
                            self.region[p] = id;
                        }
                    }
                }
                PoreRegion::Elements(ids) => {
                    let mut member = vec![false; net.tri.points.len()];
                    for &i in ids {
                        if let Some(x) = member.get_mut(i as usize) {
                            *x = true;
                        }
                    }
                    for p in 0..np {
                        let touches = net
                            .tets_of(p)
                            .iter()
                            .any(|&t| net.tri.tets[t as usize].v.iter().any(|&i| member[i as usize]));
                        if touches {
                            self.region[p] = id;
                        }
                    }
                }
                PoreRegion::Point(x) => {
                    let nearest = (0..np)
                        .map(|p| ((net.centre[p] - x).norm_squared(), p))
                        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    if let Some((_, p)) = nearest {
                        self.region[p] = id;
                    }
                }
            }
        }
        for (b, bc) in self.boundaries.iter().enumerate() {
            if let BoundaryKind::Flux(q) = bc.kind {
                let total: f64 = (0..np).filter(|&p| self.region[p] == b as u32).map(|p| net.volume[p]).sum();
                if total > 0.0 {
                    for p in 0..np {
                        if self.region[p] == b as u32 {
                            self.source[p] = q * net.volume[p] / total;
                        }
                    }
                }
            }
        }
        self.boundary_flow = vec![0.0; self.boundaries.len()];
        let added = self.hold_pressures();
        self.hold_temperatures();
        self.update_pressure();
        added
    }

    /// Drops the stiffness estimate (the fluid changed): the next step makes a new one.
    pub fn forget_stiffness(&mut self) {
        self.stiffest = None;
        self.estimated = false;
    }

    /// Whether the network and the fluid's lanes agree with each other and with `n` elements
    /// (see [`PoreNetwork::consistent`]); the error names what does not.
    pub fn consistent(&self, n: usize) -> Result<(), String> {
        self.network.consistent(n)?;
        let pores = self.network.pore_count();
        let throats = self.network.throats.len();
        let regions = self.boundaries.len();
        let fail = |what: String| Err(format!("pore fluid lanes do not match the pore network: {what}"));
        let lanes = [self.mass.len(), self.pressure.len(), self.region.len(), self.source.len()];
        if lanes.iter().any(|&l| l != pores) {
            return fail(format!("mass, pressure, region and source of {lanes:?} entries for {pores} pores"));
        }
        if !(self.temperature.is_empty() || self.temperature.len() == pores) {
            return fail(format!("{} temperatures for {pores} pores", self.temperature.len()));
        }
        if self.flow.len() != throats {
            return fail(format!("{} throat flows for {throats} throats", self.flow.len()));
        }
        let totals = [self.boundary_flow.len(), self.region_mass.len(), self.region_heat.len()];
        if totals.iter().any(|&l| l != regions) {
            return fail(format!("boundary flows and totals of {totals:?} entries for {regions} regions"));
        }
        if let Some((p, r)) = self.region.iter().enumerate().find(|(_, &r)| r != FREE && r as usize >= regions) {
            return fail(format!("pore {p} is in boundary region {r} of {regions}"));
        }
        for (b, bc) in self.boundaries.iter().enumerate() {
            if let PoreRegion::Elements(ids) = &bc.region {
                if let Some(&i) = ids.iter().find(|&&i| i as usize >= n) {
                    return fail(format!("boundary region {b} lists element {i}, and the model has {n}"));
                }
            }
        }
        Ok(())
    }

    /// The pressure pore `p` is held at, when a boundary region holds it.
    pub fn fixed_pressure(&self, p: usize) -> Option<f64> {
        match self.region[p] {
            FREE => None,
            b => match self.boundaries[b as usize].kind {
                BoundaryKind::Pressure(v) => Some(v),
                _ => None,
            },
        }
    }

    /// The temperature pore `p` is held at, when a fixed-pressure region with a temperature
    /// holds it (and the heat field is on).
    pub fn fixed_temperature(&self, p: usize) -> Option<f64> {
        match self.region[p] {
            FREE => None,
            _ if self.temperature.is_empty() => None,
            b => match self.boundaries[b as usize] {
                PoreBoundary { kind: BoundaryKind::Pressure(_), temperature, .. } => temperature,
                _ => None,
            },
        }
    }

    /// T − T0 of pore `p`'s fluid (0 with the heat field off).
    #[inline]
    pub fn excess_temperature(&self, p: usize) -> f64 {
        self.temperature.get(p).map_or(0.0, |t| t - self.reference)
    }

    /// The mass pore `p` holds at (gauge) pressure `pressure`, its volume and temperature:
    /// m = ρ0·V·(1 + p/K_f − β_f·(T − T0)), the equation of state solved for the mass.
    fn mass_at(&self, p: usize, pressure: f64) -> f64 {
        let (k, rho0) = (self.fluid.bulk_modulus, self.fluid.density);
        if self.temperature.is_empty() {
            rho0 * self.network.volume[p] * (1.0 + pressure / k)
        } else {
            let beta = self.fluid.heat.expansion;
            rho0 * self.network.volume[p] * (1.0 + pressure / k - beta * self.excess_temperature(p))
        }
    }

    /// Sets each fixed-pressure pore's mass to its pressure, volume (and temperature); returns
    /// the mass added, booked to its region with its heat c_f·Δm·(T − T0).
    pub(crate) fn hold_pressures(&mut self) -> f64 {
        let c_f = self.fluid.heat.specific_heat;
        let mut added = 0.0;
        for p in 0..self.mass.len() {
            if let Some(v) = self.fixed_pressure(p) {
                let m = self.mass_at(p, v);
                let dm = m - self.mass[p];
                added += dm;
                let b = self.region[p] as usize;
                self.region_mass[b] += dm;
                if !self.temperature.is_empty() {
                    self.region_heat[b] += c_f * dm * self.excess_temperature(p);
                }
                self.mass[p] = m;
            }
        }
        added
    }

    /// Sets each pore a region holds at a temperature to it, booking the heat to the region.
    pub(crate) fn hold_temperatures(&mut self) {
        if self.temperature.is_empty() {
            return;
        }
        let c_f = self.fluid.heat.specific_heat;
        for p in 0..self.mass.len() {
            if let Some(t) = self.fixed_temperature(p) {
                let b = self.region[p] as usize;
                self.region_heat[b] += c_f * self.mass[p] * (t - self.temperature[p]);
                self.temperature[p] = t;
            }
        }
    }

    /// p = K_f·(m / (ρ0 V) − 1) in every pore; with the heat field on,
    /// p = K_f·(m / (ρ0 V) − 1 + β_f·(T − T0)).
    pub fn update_pressure(&mut self) {
        let (k, rho0) = (self.fluid.bulk_modulus, self.fluid.density);
        let vol = &self.network.volume;
        if self.temperature.is_empty() {
            self.pressure.par_iter_mut().zip(self.mass.par_iter()).zip(vol.par_iter()).for_each(|((p, m), v)| {
                *p = k * (m / (rho0 * v) - 1.0);
            });
        } else {
            let (beta, t0) = (self.fluid.heat.expansion, self.reference);
            let t = &self.temperature;
            self.pressure.par_iter_mut().zip(self.mass.par_iter()).zip(vol.par_iter()).enumerate().for_each(
                |(i, ((p, m), v))| {
                    *p = k * (m / (rho0 * v) - 1.0 + beta * (t[i] - t0));
                },
            );
        }
    }

    /// Density of each pore's fluid (kg/m³).
    pub fn density(&self) -> Vec<f64> {
        self.mass.iter().zip(&self.network.volume).map(|(m, v)| m / v).collect()
    }

    /// Total fluid mass in the network (kg).
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// The network's pore volume, Σ V_p (m³).
    pub fn pore_volume(&self) -> f64 {
        self.network.volume.iter().sum()
    }

    /// The fluid's mean gauge pressure over the network, each pore weighted by its volume
    /// (Pa): what a pore-pressure transducer in a drained cell's line reads once the fluid is at
    /// rest, and the u of effective stress σ' = σ − u.
    pub fn mean_pressure(&self) -> f64 {
        let v = &self.network.volume;
        self.pressure.iter().zip(v).map(|(p, v)| p * v).sum::<f64>() / self.pore_volume()
    }

    /// The flow's critical step and the pore that sets it: min over pores not held at a
    /// pressure of V_i / (K_f·Σ_j g_ij); infinite when no pore is connected.
    pub fn critical_dt(&self) -> (usize, f64) {
        let net = &self.network;
        let k = self.fluid.bulk_modulus;
        (0..net.pore_count())
            .into_par_iter()
            .filter(|&p| self.fixed_pressure(p).is_none())
            .map(|p| {
                let g: f64 = net.throats_of(p).iter().map(|&t| net.conductance[t as usize]).sum();
                (p, if g > 0.0 { net.volume[p] / (k * g) } else { f64::INFINITY })
            })
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
            .unwrap_or((0, f64::INFINITY))
    }

    /// Follows the elements (rebuilding the network when they have moved far, carrying the
    /// fluid over) and advances the fluid by `dt` in sub-steps under its critical step.
    pub fn advance(&mut self, m: &Model, dt: f64) -> Result<()> {
        self.follow(m)?;
        let n = self.substeps_needed(m, dt)?;
        let h = dt / n as f64;
        for _ in 0..n {
            self.substep(h);
        }
        self.substeps = n;
        if let Some(p) = self.pressure.iter().position(|p| !p.is_finite()) {
            return Err(Error::InvalidScene(format!("pore {p}'s pressure is not finite after the flow update")));
        }
        Ok(())
    }

    /// The first half of [`Self::advance`]: the network follows the elements (rebuilt, the fluid
    /// carried over, once an element has drifted `rebuild_drift` × the mean radius; otherwise
    /// its geometry refreshed), the pressures follow the volumes, and the fluid's stiffness on
    /// the grains is estimated once per build (for the guard's message). The GPU backend calls
    /// it at each upload.
    pub fn follow(&mut self, m: &Model) -> Result<()> {
        let drift_limit = self.fluid.rebuild_drift * m.mean_radius();
        if self.network.drift(m) > drift_limit {
            self.rebuild(m)?;
        } else {
            self.network.refresh(m, &self.fluid);
        }
        self.update_pressure();
        if !self.estimated {
            if let Some(s) = m.stiffest_with_fluid(self) {
                if self.stiffest.is_none_or(|old| s.critical_dt < old.critical_dt) {
                    self.stiffest = Some(s);
                }
            }
            self.estimated = true;
        }
        Ok(())
    }

    /// The flow sub-steps a mechanical step `dt` needs on the current network,
    /// ⌈dt / (0.9 · the stable flow step)⌉, or the guard's error naming the pore when that is more
    /// than the fluid's `max_substeps`.
    pub fn substeps_needed(&self, m: &Model, dt: f64) -> Result<u32> {
        let (pore, crit) = self.critical_dt();
        let n = substeps_for(dt, crit);
        if n > self.fluid.max_substeps as f64 {
            let t = self.network.tets_of(pore)[0] as usize;
            return Err(Error::Unstable(Box::new(Instability {
                step: m.clock.step,
                particle: self.network.tri.tets[t].v[0] as usize,
                what: format!(
                    "bounds pore {pore}, whose fluid needs {n} flow sub-steps of the mechanical step (stable flow \
                     step V_p/(K_f·Σg) = {crit:.3e} s), more than the fluid's max_substeps = {}",
                    self.fluid.max_substeps
                ),
                dt,
                critical_dt: crit,
                standard_dt: m.standard_dt().unwrap_or(f64::NAN),
                fix: Some(format!(
                    "Fix: raise the fluid's max_substeps to {n} or more, lower its bulk_modulus or raise its \
                     viscosity (the flow step scales with μ/K_f), or lower dt"
                )),
                suggest: self.substep_fixes(n, dt, crit),
            })));
        }
        Ok(n as u32)
    }

    /// The numbers of the fix for a flow that needs `n` sub-steps of its stable step `crit`
    /// where `max_substeps` are allowed: the flow step scales with μ/K_f, so each of max_substeps,
    /// K_f, μ and dt alone brings `n` within the cap when moved by the ratio n / max_substeps.
    fn substep_fixes(&self, n: f64, dt: f64, crit: f64) -> Vec<Suggestion> {
        let cap = self.fluid.max_substeps as f64;
        // The largest dt that max_substeps sub-steps cover: n = ⌈dt / (FLOW_SAFETY·crit)⌉.
        let fits = FLOW_SAFETY * crit * cap / dt;
        vec![
            Suggestion::above("max_substeps", n - 1.0, ""),
            Suggestion::below("bulk_modulus", self.fluid.bulk_modulus * fits, "Pa"),
            Suggestion::above("viscosity", self.fluid.viscosity / fits, "Pa·s"),
            Suggestion::below("dt", dt * fits, "s"),
        ]
    }

    /// One explicit Euler step of length `h`.
    pub fn substep(&mut self, h: f64) {
        let rho0 = self.fluid.density;
        self.boundary_mass += self.hold_pressures();
        self.hold_temperatures();
        self.update_pressure();
        let net = &self.network;
        let pressure = &self.pressure;
        self.flow
            .par_iter_mut()
            .zip(net.throats.par_iter())
            .zip(net.conductance.par_iter())
            .for_each(|((q, th), g)| *q = g * (pressure[th.a as usize] - pressure[th.b as usize]));
        let flow = &self.flow;
        let source = &self.source;
        // Net volumetric inflow of each pore through its own row of throats.
        let row_sum = |per_throat: &[f64]| -> Vec<f64> {
            (0..net.pore_count())
                .into_par_iter()
                .map(|p| {
                    net.throats_of(p)
                        .iter()
                        .map(|&t| {
                            let th = &net.throats[t as usize];
                            if th.a as usize == p {
                                -per_throat[t as usize]
                            } else {
                                per_throat[t as usize]
                            }
                        })
                        .sum::<f64>()
                })
                .collect()
        };
        let inflow = row_sum(flow);
        for b in self.boundary_flow.iter_mut() {
            *b = 0.0;
        }
        if self.temperature.is_empty() {
            for p in 0..self.mass.len() {
                self.mass[p] += rho0 * h * (inflow[p] + source[p]);
                self.boundary_mass += rho0 * h * source[p];
                if self.region[p] != FREE {
                    let b = self.region[p] as usize;
                    self.boundary_flow[b] += source[p] - inflow[p];
                    self.region_mass[b] += rho0 * h * source[p];
                }
            }
        } else {
            // Heat carried by the flow, upwind: a throat's flow carries the temperature of
            // the pore it leaves. One value per throat, read by both of its pores' rows, so
            // what one pore loses the other gains (Σ m·(T − T0) conserved to round-off).
            let excess: Vec<f64> = (0..self.mass.len()).map(|p| self.excess_temperature(p)).collect();
            let carried: Vec<f64> = (self.flow.par_iter().zip(net.throats.par_iter()))
                .map(|(q, th)| q * if *q > 0.0 { excess[th.a as usize] } else { excess[th.b as usize] })
                .collect();
            let heat_in = row_sum(&carried);
            let c_f = self.fluid.heat.specific_heat;
            for p in 0..self.mass.len() {
                let m0 = self.mass[p];
                // An injection brings its region's temperature; a draw takes the pore's own.
                let supplied = match self.region[p] {
                    FREE => excess[p],
                    b => match self.boundaries[b as usize].temperature {
                        Some(t) if source[p] > 0.0 => t - self.reference,
                        _ => excess[p],
                    },
                };
                let m1 = m0 + rho0 * h * (inflow[p] + source[p]);
                let e1 = m0 * excess[p] + rho0 * h * (heat_in[p] + source[p] * supplied);
                self.mass[p] = m1;
                if m1 > 0.0 {
                    self.temperature[p] = self.reference + e1 / m1;
                }
                self.boundary_mass += rho0 * h * source[p];
                if self.region[p] != FREE {
                    let b = self.region[p] as usize;
                    self.boundary_flow[b] += source[p] - inflow[p];
                    self.region_mass[b] += rho0 * h * source[p];
                    self.region_heat[b] += c_f * rho0 * h * source[p] * supplied;
                }
            }
        }
        self.boundary_mass += self.hold_pressures();
        self.hold_temperatures();
        self.update_pressure();
    }

    /// Builds the network anew for the current packing and carries the fluid over: each new
    /// pore takes the density of the old pore whose centre is nearest its own, and the masses
    /// of pores not held at a pressure are scaled so that their total is unchanged.
    pub fn rebuild(&mut self, m: &Model) -> Result<()> {
        let old_density = self.density();
        let old_centre = self.network.centre.clone();
        let old_total = self.total_mass();
        let old_free_mass: f64 =
            (0..self.mass.len()).filter(|&p| self.fixed_pressure(p).is_none()).map(|p| self.mass[p]).sum();
        let thermal = !self.temperature.is_empty();
        let old_free_heat = self.free_heat();
        let old_held = self.held_by_region();
        let mut net = PoreNetwork::build(m)?;
        net.refresh(m, &self.fluid);
        let nearest: Vec<usize> = net
            .centre
            .par_iter()
            .map(|c| {
                old_centre
                    .iter()
                    .enumerate()
                    .map(|(i, o)| ((o - c).norm_squared(), i))
                    .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                    .map(|(_, i)| i)
                    .unwrap_or(0)
            })
            .collect();
        let mass: Vec<f64> = nearest.iter().zip(&net.volume).map(|(&o, v)| old_density[o] * v).collect();
        if thermal {
            self.temperature = nearest.iter().map(|&o| self.temperature[o]).collect();
        }
        self.flow = vec![0.0; net.throats.len()];
        self.pressure = vec![0.0; mass.len()];
        self.network = net;
        self.mass = mass;
        // The regions' totals are booked below, from what their pores held before and after.
        let (region_mass, region_heat) = (self.region_mass.clone(), self.region_heat.clone());
        self.resolve_boundaries();
        (self.region_mass, self.region_heat) = (region_mass, region_heat);
        let free: Vec<usize> = (0..self.mass.len()).filter(|&p| self.fixed_pressure(p).is_none()).collect();
        let new_free_mass: f64 = free.iter().map(|&p| self.mass[p]).sum();
        if new_free_mass > 0.0 {
            let s = old_free_mass / new_free_mass;
            for &p in &free {
                self.mass[p] *= s;
            }
            if thermal {
                // The free fluid's heat is carried over too: its temperatures shift by one
                // amount so that Σ m·(T − T0) over the free pores is unchanged.
                let shift = (old_free_heat - self.free_heat()) / old_free_mass.max(f64::MIN_POSITIVE);
                for &p in &free {
                    if self.fixed_temperature(p).is_none() {
                        self.temperature[p] += shift;
                    }
                }
            }
        }
        self.update_pressure();
        // What the fixed pressures hold changed with the pores; the boundaries supplied it.
        self.boundary_mass += self.total_mass() - old_total;
        let new_held = self.held_by_region();
        for (b, (old, new)) in old_held.iter().zip(&new_held).enumerate() {
            self.region_mass[b] += new.0 - old.0;
            self.region_heat[b] += new.1 - old.1;
        }
        self.rebuilds += 1;
        self.estimated = false;
        Ok(())
    }

    /// Σ m·(T − T0) over the pores not held at a pressure (kg·K; 0 with the heat field off).
    fn free_heat(&self) -> f64 {
        (0..self.mass.len())
            .filter(|&p| self.fixed_pressure(p).is_none())
            .map(|p| self.mass[p] * self.excess_temperature(p))
            .sum()
    }

    /// The mass and heat c_f·m·(T − T0) the fixed-pressure pores of each region hold.
    fn held_by_region(&self) -> Vec<(f64, f64)> {
        let c_f = self.fluid.heat.specific_heat;
        let mut out = vec![(0.0, 0.0); self.boundaries.len()];
        for p in 0..self.mass.len() {
            if self.fixed_pressure(p).is_some() {
                let o = &mut out[self.region[p] as usize];
                o.0 += self.mass[p];
                o.1 += c_f * self.mass[p] * self.excess_temperature(p);
            }
        }
        out
    }

    /// Sets the fluid to the steady state of the current network: the pressures for which
    /// every free pore's throat flows and source balance (Kirchhoff), found by conjugate
    /// gradients (Jacobi-preconditioned) to a relative residual `tol`; then the masses, the
    /// throat flows and the boundary flows follow. Returns the iterations used. Needs at
    /// least one fixed-pressure pore (otherwise the level is undetermined).
    pub fn solve_steady(&mut self, tol: f64) -> Result<usize> {
        let np = self.network.pore_count();
        if !(0..np).any(|p| self.fixed_pressure(p).is_some()) {
            return Err(Error::InvalidScene(
                "the steady pore pressure needs a fixed-pressure boundary region (set one with a pressure)".into(),
            ));
        }
        let net = &self.network;
        let fixed: Vec<Option<f64>> = (0..np).map(|p| self.fixed_pressure(p)).collect();
        let other = |p: usize, t: u32| {
            let th = &net.throats[t as usize];
            if th.a as usize == p {
                th.b as usize
            } else {
                th.a as usize
            }
        };
        let diag: Vec<f64> =
            (0..np).map(|p| net.throats_of(p).iter().map(|&t| net.conductance[t as usize]).sum::<f64>()).collect();
        // A·x over free pores (fixed pores read as 0 in x).
        let apply = |x: &[f64], out: &mut [f64]| {
            out.par_iter_mut().enumerate().for_each(|(p, o)| {
                *o = if fixed[p].is_some() {
                    0.0
                } else {
                    let mut s = diag[p] * x[p];
                    for &t in net.throats_of(p) {
                        let q = other(p, t);
                        if fixed[q].is_none() {
                            s -= net.conductance[t as usize] * x[q];
                        }
                    }
                    s
                };
            });
        };
        let b: Vec<f64> = (0..np)
            .map(|p| {
                if fixed[p].is_some() {
                    return 0.0;
                }
                let mut s = self.source[p];
                for &t in net.throats_of(p) {
                    if let Some(v) = fixed[other(p, t)] {
                        s += net.conductance[t as usize] * v;
                    }
                }
                s
            })
            .collect();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut x: Vec<f64> = (0..np).map(|p| if fixed[p].is_some() { 0.0 } else { self.pressure[p] }).collect();
        let mut ax = vec![0.0; np];
        apply(&x, &mut ax);
        let mut r: Vec<f64> = b.iter().zip(&ax).map(|(b, a)| b - a).collect();
        let precond =
            |r: &[f64]| -> Vec<f64> { r.iter().zip(&diag).map(|(r, d)| if *d > 0.0 { r / d } else { 0.0 }).collect() };
        let mut z = precond(&r);
        let mut d = z.clone();
        let mut rz = dot(&r, &z);
        let bnorm = dot(&b, &b).sqrt().max(f64::MIN_POSITIVE);
        let mut iters = 0;
        let limit = 10 * np + 100;
        while dot(&r, &r).sqrt() > tol * bnorm {
            if iters >= limit {
                return Err(Error::InvalidScene(format!(
                    "the steady pore pressure did not converge in {limit} iterations (is part of the network \
                     cut off from every fixed-pressure region?)"
                )));
            }
            apply(&d, &mut ax);
            let alpha = rz / dot(&d, &ax);
            for p in 0..np {
                x[p] += alpha * d[p];
                r[p] -= alpha * ax[p];
            }
            z = precond(&r);
            let rz1 = dot(&r, &z);
            let beta = rz1 / rz;
            rz = rz1;
            for p in 0..np {
                d[p] = z[p] + beta * d[p];
            }
            iters += 1;
        }
        let before = self.total_mass();
        for p in 0..np {
            let v = fixed[p].unwrap_or(x[p]);
            self.mass[p] = self.mass_at(p, v);
        }
        self.boundary_mass += self.total_mass() - before;
        self.update_pressure();
        // The flows of that state (a zero-length step leaves the masses as they are).
        self.substep(0.0);
        Ok(iters)
    }
}
