//! Heat in the pore fluid (paper 003 §3.3: "the pressure of the fluid is a function of its
//! density and temperature"), when the heat field (`conduction`) and pore flow are both on.
//!
//! Each pore's fluid carries its own temperature T_p (K): a two-temperature model, the fluid
//! and the grains each with their own heat capacity, exchanging heat where they touch.
//!
//! - **Equation of state**: p = K_f·(ρ/ρ0 − 1 + β_f·(T_p − T0)), β_f the fluid's volumetric
//!   thermal expansion (1/K, water ≈ 2.1e-4 at 20 °C) and T0 the heat field's reference
//!   temperature: ρ = ρ0·(1 + p/K_f − β_f·(T − T0)) to first order, so a sealed pore heated by
//!   ΔT at constant volume rises by K_f·β_f·ΔT (thermal pressurisation).
//! - **Advection** (in [`super::flow::PoreFlow::substep`]): the mass ρ0·q a throat carries
//!   brings c_f·(T − T0) of the pore it leaves (upwind); fluid injected by a flux region comes
//!   at the region's temperature, a fixed-pressure region with a temperature holds its pores at
//!   it (a reservoir), without one its pores drain at their own temperature.
//! - **Exchange with the grains** ([`PoreFlow::exchange_heat`]): the fluid of pore p and an
//!   element i at a corner of one of its tetrahedra exchange Q = G·(T_i − T_p) with
//!   G = (Nu/2)·k_f·Ω·r_i, Ω the tetrahedron's solid angle at i: the element's surface in that
//!   tetrahedron (Ω·r²) with a film coefficient h = Nu·k_f/(2r). Around an interior element the
//!   solid angles add up to 4π, so with Nu = 2 the element exchanges 4π·k_f·r·(T_i − T_fluid):
//!   exactly a sphere conducting into a still fluid. Forward Euler, each pore and each element
//!   summing its own corners with the same G (Σ C·T conserved to round-off), sub-stepped
//!   under the stable step of both sides (min of c_f·m_p/ΣG_p and C_i/ΣG_i).
//!
//! Heat the fluid carries between pores is not also conducted through the fluid (the grains
//! conduct, `conduction`); the compression work p·dV and viscous heating are left out.

use super::flow::PoreFlow;
use super::geometry::solid_angle;
use crate::effects::conduction::lanes::{FIXED, INSULATED};
use crate::error::{Error, Instability, Result, Suggestion};
use crate::model::Model;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The pore fluid's thermal properties (water at 20 °C by default).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FluidHeat {
    /// Specific heat c_f (J/(kg·K)).
    pub specific_heat: f64,
    /// Volumetric thermal expansion β_f (1/K) in the equation of state.
    pub expansion: f64,
    /// Thermal conductivity k_f (W/(m·K)), for the exchange with the grains.
    pub conductivity: f64,
    /// Nusselt number of the grain–fluid exchange, h·d/k_f (2: a sphere in still fluid; 0: no
    /// exchange).
    pub nusselt: f64,
}

impl Default for FluidHeat {
    fn default() -> Self {
        FluidHeat { specific_heat: 4186.0, expansion: 2.1e-4, conductivity: 0.6, nusselt: 2.0 }
    }
}

impl FluidHeat {
    /// Checks every property, naming the first bad one.
    pub fn check(&self) -> Result<()> {
        use crate::error::check_positive;
        check_positive("fluid specific_heat", self.specific_heat, false)?;
        check_positive("fluid conductivity", self.conductivity, true)?;
        check_positive("fluid nusselt", self.nusselt, true)?;
        if !self.expansion.is_finite() {
            return Err(Error::param("fluid expansion", self.expansion, "must be a finite number (1/K)"));
        }
        Ok(())
    }
}

impl PoreFlow {
    /// With the heat field on, gives every pore a temperature when it has none (each the mean
    /// of its corner elements' temperatures, weighted by the tetrahedra's volumes: the fluid
    /// starts in equilibrium with the grains around it) and takes T0 from the field; with it
    /// off, drops them.
    pub fn fit_temperature(&mut self, m: &Model) {
        let th = &m.particles.thermal;
        if !m.settings.heat.enabled || th.temperature.len() != m.len() {
            self.temperature.clear();
            return;
        }
        self.reference = m.settings.heat.reference;
        if self.temperature.len() == self.mass.len() {
            return;
        }
        let net = &self.network;
        let pos = &m.particles.pos;
        self.temperature = (0..net.pore_count())
            .map(|p| {
                let (mut tw, mut w) = (0.0, 0.0);
                for &t in net.tets_of(p) {
                    let v = net.tri.tets[t as usize].v;
                    let vol = super::geometry::tet_volume(v.map(|i| pos[i as usize])).abs();
                    tw += vol * v.iter().map(|&i| th.temperature[i as usize]).sum::<f64>() / 4.0;
                    w += vol;
                }
                if w > 0.0 {
                    tw / w
                } else {
                    self.reference
                }
            })
            .collect();
        self.hold_temperatures();
        self.update_pressure();
    }

    /// The exchange conductance G = (Nu/2)·k_f·Ω·r of every tetrahedron corner (`4·tet +
    /// corner`), W/K; zero at an insulated element or one without heat capacity.
    fn corner_conductance(&self, m: &Model) -> Vec<f64> {
        let h = self.fluid.heat;
        let scale = 0.5 * h.nusselt * h.conductivity;
        let (pos, rad) = (&m.particles.pos, &m.particles.radius);
        let th = &m.particles.thermal;
        self.network
            .tri
            .tets
            .par_iter()
            .flat_map_iter(|tet| {
                let x = tet.v.map(|i| pos[i as usize]);
                (0..4).map(move |c| {
                    let i = tet.v[c] as usize;
                    if scale == 0.0 || th.mode[i] == INSULATED || th.capacity[i] <= 0.0 {
                        return 0.0;
                    }
                    let omega = solid_angle(x[c], x[(c + 1) % 4], x[(c + 2) % 4], x[(c + 3) % 4]);
                    scale * omega * rad[i]
                })
            })
            .collect()
    }

    /// The exchange's corner conductances ([`Self::corner_conductance`]) and the forward-Euler
    /// sub-steps a mechanical step `dt` needs under the stable step of both sides, min of
    /// c_f·m_p/ΣG_p and C_i/ΣG_i (0 when nothing exchanges), or the guard's error naming the
    /// pore or the element beyond the fluid's `max_substeps`. The GPU backend sizes its first
    /// batch's exchange with it ([`Self::exchange_substeps_needed`]).
    fn exchange_plan(&self, m: &Model, dt: f64) -> Result<(Vec<f64>, u32)> {
        let g = self.corner_conductance(m);
        let c_f = self.fluid.heat.specific_heat;
        let net = &self.network;
        let pore_g: Vec<f64> = (0..net.pore_count())
            .into_par_iter()
            .map(|p| net.tets_of(p).iter().map(|&t| g[4 * t as usize..4 * t as usize + 4].iter().sum::<f64>()).sum())
            .collect();
        let elem_g: Vec<f64> = (0..m.len())
            .into_par_iter()
            .map(|i| {
                net.elem_corners[net.elem_start[i] as usize..net.elem_start[i + 1] as usize]
                    .iter()
                    .map(|&e| g[e as usize])
                    .sum()
            })
            .collect();
        // The stable step: the smallest capacity over conductance of either side.
        let th = &m.particles.thermal;
        let pore_limit = (0..net.pore_count())
            .filter(|&p| pore_g[p] > 0.0 && self.fixed_temperature(p).is_none())
            .map(|p| (c_f * self.mass[p] / pore_g[p], p, true));
        let elem_limit = (0..m.len())
            .filter(|&i| elem_g[i] > 0.0 && th.mode[i] != FIXED)
            .map(|i| (th.capacity[i] / elem_g[i], i, false));
        let Some((crit, who, is_pore)) =
            pore_limit.chain(elem_limit).min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        else {
            return Ok((g, 0));
        };
        let n = (dt / (0.9 * crit)).ceil().max(1.0);
        if n > self.fluid.max_substeps as f64 || !crit.is_finite() || crit <= 0.0 {
            let (particle, what) = if is_pore {
                let t = net.tets_of(who)[0] as usize;
                (net.tri.tets[t].v[0] as usize, format!("bounds pore {who}, whose fluid"))
            } else {
                (who, "exchanges heat with the pore fluid and".to_string())
            };
            return Err(Error::Unstable(Box::new(Instability {
                step: m.clock.step,
                particle,
                what: format!(
                    "{what} needs {n} sub-steps of the fluid–grain heat exchange (stable step C/ΣG = {crit:.3e} s), \
                     more than the fluid's max_substeps = {}",
                    self.fluid.max_substeps
                ),
                dt,
                critical_dt: crit,
                standard_dt: m.standard_dt().unwrap_or(f64::NAN),
                fix: Some(format!(
                    "Fix: raise the fluid's max_substeps to {n} or more, lower its nusselt or conductivity, raise \
                     its specific_heat or the elements' specific heat, or lower dt"
                )),
                // The exchange's conductances scale with nusselt: each of these alone brings n
                // within the cap (n = ⌈dt / (0.9·crit)⌉).
                suggest: if crit.is_finite() && crit > 0.0 {
                    let fits = 0.9 * crit * self.fluid.max_substeps as f64 / dt;
                    vec![
                        Suggestion::above("max_substeps", n - 1.0, ""),
                        Suggestion::below("nusselt", self.fluid.heat.nusselt * fits, ""),
                        Suggestion::below("dt", dt * fits, "s"),
                    ]
                } else {
                    Vec::new()
                },
            })));
        }
        Ok((g, n as u32))
    }

    /// The sub-steps of the fluid–grain heat exchange a mechanical step `dt` needs now (0 when
    /// nothing exchanges), or the guard's error beyond the fluid's `max_substeps`.
    pub fn exchange_substeps_needed(&self, m: &Model, dt: f64) -> Result<u32> {
        if self.temperature.is_empty() {
            return Ok(0);
        }
        self.exchange_plan(m, dt).map(|(_, n)| n)
    }

    /// Exchanges heat between each pore's fluid and the elements at its corners for `dt`, in
    /// as many forward-Euler sub-steps as the stable step of both sides needs (the guard's
    /// error, naming the pore or the element, beyond the fluid's `max_substeps`). Each pore
    /// and each element sums its own corners with the same conductance, so the heat one gains
    /// the other loses; a fixed element keeps its temperature, a pore held at a temperature
    /// is reset to it (booked to its region).
    pub fn exchange_heat(&mut self, m: &mut Model, dt: f64) -> Result<()> {
        if self.temperature.is_empty() {
            return Ok(());
        }
        let (g, n) = self.exchange_plan(m, dt)?;
        if n == 0 {
            self.exchange_substeps = 0;
            return Ok(());
        }
        let c_f = self.fluid.heat.specific_heat;
        let h = dt / f64::from(n);
        for _ in 0..n {
            let th = &m.particles.thermal;
            let (tp, te) = (&self.temperature, &th.temperature);
            let net = &self.network;
            let pore_q: Vec<f64> = (0..net.pore_count())
                .into_par_iter()
                .map(|p| {
                    let mut q = 0.0;
                    for &t in net.tets_of(p) {
                        let v = net.tri.tets[t as usize].v;
                        for c in 0..4 {
                            q += g[4 * t as usize + c] * (te[v[c] as usize] - tp[p]);
                        }
                    }
                    q
                })
                .collect();
            let elem_q: Vec<f64> = (0..te.len())
                .into_par_iter()
                .map(|i| {
                    let mut q = 0.0;
                    for &e in &net.elem_corners[net.elem_start[i] as usize..net.elem_start[i + 1] as usize] {
                        let p = net.tet_pore[(e / 4) as usize] as usize;
                        q += g[e as usize] * (tp[p] - te[i]);
                    }
                    q
                })
                .collect();
            for (p, q) in pore_q.iter().enumerate() {
                if *q != 0.0 {
                    self.temperature[p] += h * q / (c_f * self.mass[p]);
                }
            }
            let th = &mut m.particles.thermal;
            for (i, q) in elem_q.iter().enumerate() {
                if *q != 0.0 && th.mode[i] != FIXED {
                    th.temperature[i] += h * q / th.capacity[i];
                }
            }
            self.hold_temperatures();
        }
        self.exchange_substeps = n;
        self.update_pressure();
        Ok(())
    }

    /// The heat the pore fluid holds, Σ c_f·m·(T − T0) (J; 0 with the heat field off).
    pub fn fluid_heat(&self) -> f64 {
        let c_f = self.fluid.heat.specific_heat;
        (0..self.mass.len()).map(|p| c_f * self.mass[p] * self.excess_temperature(p)).sum()
    }

    /// Each element's pore-fluid temperature: the mean over the tetrahedra it is a corner of,
    /// weighted by their volumes (as [`PoreFlow::element_pressure`]); empty with the heat
    /// field off.
    pub fn element_temperature(&self, pos: &[crate::physics::Vec3]) -> Vec<f64> {
        if self.temperature.is_empty() {
            return Vec::new();
        }
        self.network.element_mean(pos, &self.temperature, self.reference)
    }
}
