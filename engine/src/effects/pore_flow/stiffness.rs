//! The pore fluid as a spring on the grains. Squeezing a sealed pore by dV raises its pressure
//! by K_f·(ρ/ρ0)·dV/V, so an element at its corners meets the stiffness
//! K_f·(ρ/ρ0)·|∂V/∂x|²/V of that pore on top of its contacts'. A stiff fluid in small pores can
//! therefore make the mechanical step unstable although every contact allows it (a 1.6 µs step
//! that the contacts take blew a bonded block apart within 100 steps once water of 200 MPa filled
//! its pores), and the guard then stops the run on a runaway speed with a fix that points at
//! the contacts. When it does and pore flow is on, the fluid's share is estimated and, where it
//! explains the failure, named instead.

use super::flow::{FluidSpring, PoreFlow, StiffestElement};
use crate::error::{Error, Instability, Suggestion};
use crate::model::Model;
use crate::physics::timestep::critical_step;
use crate::physics::Vec3;
use rayon::prelude::*;

impl PoreFlow {
    /// The fluid's stiffness on element `i`: Σ over the pores at its corners that no boundary
    /// holds at a pressure of K_f·(ρ/ρ0)·|∂V_p/∂x_i|²/V_p, ∂V_p/∂x_i summed over the pore's
    /// tetrahedra (the gradient the pressure force uses), along the degrees of freedom `fixed`
    /// leaves free (`dof` bits), with a pore that drains within `dt` sharing its neighbours'
    /// volume.
    pub fn fluid_spring(&self, pos: &[Vec3], fixed: u8, i: usize, dt: f64) -> FluidSpring {
        let net = &self.network;
        let mut grads: Vec<(u32, Vec3)> = Vec::new();
        if i + 1 < net.elem_start.len() {
            for &e in &net.elem_corners[net.elem_start[i] as usize..net.elem_start[i + 1] as usize] {
                let (t, c) = ((e / 4) as usize, (e % 4) as usize);
                let p = net.tet_pore[t];
                let g = super::pressure_forces::volume_gradient(pos, net.tri.tets[t].v, c) * net.orient[t];
                match grads.iter_mut().find(|(q, _)| *q == p) {
                    Some((_, sum)) => *sum += g,
                    None => grads.push((p, g)),
                }
            }
        }
        let (k, rho0) = (self.fluid.bulk_modulus, self.fluid.density);
        let mut spring = FluidSpring { stiffness: 0.0, pore: 0 };
        // A pore whose own flow step V/(K_f·Σg) is shorter than dt shares a squeeze with its
        // neighbours within the step: the pressure rises over their volume together.
        let volume = |p: usize| {
            let g: f64 = net.throats_of(p).iter().map(|&t| net.conductance[t as usize]).sum();
            let v = net.volume[p];
            if v < k * g * dt {
                let other = |t: u32| {
                    let th = net.throats[t as usize];
                    if th.a as usize == p {
                        th.b
                    } else {
                        th.a
                    }
                };
                v + net.throats_of(p).iter().map(|&t| net.volume[other(t) as usize]).sum::<f64>()
            } else {
                v
            }
        };
        let mut largest = 0.0;
        for (p, g) in grads {
            let p = p as usize;
            if self.fixed_pressure(p).is_some() {
                continue;
            }
            // Only the directions the element may move in load the spring (a frozen frame
            // element feels the pressure but cannot oscillate).
            let g = Vec3::from_fn(|d, _| if fixed & (1 << d) == 0 { g[d] } else { 0.0 });
            let s = k * (self.mass[p] / (rho0 * net.volume[p])) * g.norm_squared() / volume(p);
            spring.stiffness += s;
            if s > largest {
                largest = s;
                spring.pore = p;
            }
        }
        spring
    }
}

impl Model {
    /// The stiffest element for the pore fluid and its contacts together.
    pub fn stiffest_with_fluid(&self, f: &PoreFlow) -> Option<StiffestElement> {
        let p = &self.particles;
        let flow_dt = f.critical_dt().1;
        (0..self.len())
            .into_par_iter()
            .map(|i| {
                let s = f.fluid_spring(&p.pos, p.fixed[i], i, self.clock.dt);
                let contacts = self.element_stiffness(i);
                let critical_dt = critical_step(p.mass[i], contacts + s.stiffness);
                StiffestElement { critical_dt, element: i, spring: s, contacts, flow_dt }
            })
            .min_by(|a, b| a.critical_dt.total_cmp(&b.critical_dt).then(a.element.cmp(&b.element)))
    }

    /// Names the pore fluid as the cause of an instability the guard found (a runaway speed, a
    /// non-finite state) when the fluid's springs make dt too long: the element they load most,
    /// its pore, the critical step with the fluid and the fix. Any other error, or a fluid soft
    /// enough for dt, is returned as it was.
    ///
    /// The estimate bounds the stiffness from above (each pore undrained unless its own flow
    /// step is under dt, the pores of an element summed), so it explains a failure rather than
    /// stopping a run before one: a bonded block whose estimate said 2× too stiff ran stably.
    ///
    /// `flow_error`: `e` is the flow's own (more sub-steps than allowed); the fluid is blamed
    /// only when the flow was within its sub-steps on the network the estimate saw, so that the
    /// flow step has collapsed since (the grains blew up and crushed their pores), not when the
    /// flow is merely too fast for dt.
    pub fn pore_fluid_cause(&self, e: Error, flow_error: bool) -> Error {
        let Error::Unstable(inst) = &e else { return e };
        let Some(f) = self.pores.as_ref().filter(|_| self.settings.pores.enabled) else { return e };
        // Estimated when the network was (re)built: the state that failed may be chaos.
        let Some(StiffestElement { critical_dt: crit, element: i, spring, contacts, flow_dt }) = f.stiffest else {
            return e;
        };
        let flow_was_fine = self.clock.dt <= super::flow::FLOW_SAFETY * flow_dt * f.fluid.max_substeps as f64;
        if flow_error && !flow_was_fine {
            return e;
        }
        let dt = self.clock.dt;
        if dt <= crit || spring.stiffness <= contacts {
            return e;
        }
        let k_f = f.fluid.bulk_modulus;
        // The bulk modulus at which this element's critical step is dt: √2·√(m/k) = dt allows
        // k = 2m/dt² = (crit/dt)²·(k_contacts + k_fluid) in all.
        let allowed = (crit / dt).powi(2) * (contacts + spring.stiffness) - contacts;
        let k_f_stable = k_f * allowed.max(0.0) / spring.stiffness;
        Error::Unstable(Box::new(Instability {
            step: inst.step,
            particle: i,
            what: format!(
                "bounds pore {}, whose fluid (K_f = {k_f:.3e} Pa) pushes back like a spring of up to {:.3e} N/m on top \
                 of its contacts' {contacts:.3e} N/m (what the guard saw: particle {} {})",
                spring.pore, spring.stiffness, inst.particle, inst.what
            ),
            dt,
            critical_dt: crit,
            standard_dt: inst.standard_dt,
            fix: Some(format!(
                "Fix: the pores around it are small for so stiff a fluid: soften it below K_f = {k_f_stable:.3e} Pa \
                 (d.fluid = #{{ bulk_modulus: … }}; the flow step grows with it too) or lower dt below {crit:.3e} s"
            )),
            suggest: vec![Suggestion::below("bulk_modulus", k_f_stable, "Pa"), Suggestion::below("dt", crit, "s")],
        }))
    }
}
