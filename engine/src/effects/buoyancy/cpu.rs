//! The `buoyancy` stage on the CPU, a force stage between the other force stages
//! (`wall_forces`, `parallel_bond`, `rolling_resistance`, `pore_flow`) and `integrate`: every
//! element below the water level adds the buoyant force −ρ_f·V_sub·g to its force lane (V_sub
//! its submerged volume, a spherical cap where the level cuts it; `physics::buoyancy`), and,
//! with a viscosity, the Stokes drag −6π·μ·r·v scaled by the submerged fraction (killed
//! elements excepted). Each element writes only its own lane: no atomics.
//!
//! Because the buoyancy is in the force lane before `integrate`, everything that reads the
//! unbalanced force sees it: MatDEM's local damping −α·|F|·sign(v) damps what is left of
//! gravity, contacts *and* buoyancy (so a floating or submerged element settles where the
//! forces balance, with no dead band), and the status' unbalanced force of a settled submerged
//! column is zero. The force lane thus carries every force but gravity (gravity is added in
//! `integrate`, and by the status, from the settings); the contact loads
//! (`status::contact_loads`) and the walls' loads are computed from the contacts and never
//! include it.
//!
//! NOTE: the drag is an exponential integrator written as a force. With A the acceleration of
//! every other force on the element (this lane after buoyancy, plus gravity) and v the
//! half-step velocity, the exact solution of dv/dt = A − v/τ over dt (τ = m/(6π·μ·r·fraction),
//! x = dt/τ) is v·e^(−x) + A·dt·φ, φ = (1 − e^(−x))/x; the stage adds the force that makes the
//! leapfrog kick land there, F_d = −m·[v·(1 − e^(−x))/dt + A·(1 − φ)] (→ −6π·μ·r·fraction·
//! (v + A·dt/2) as x → 0: the drag on the step's mean velocity). A force computed from the
//! velocity explicitly, −v/τ, would be unstable once dt > 2τ (a fine grain in a viscous
//! fluid); this one is stable for any viscosity (the kick's velocity is bounded by |v| + |A|·dt,
//! and tends to A·τ), and a sinking element reaches the Stokes terminal speed A·τ exactly.
//! Being a force, the drag is also seen by local damping; with MatDEM's viscous damping as
//! well the terminal speed is A/(1/τ + c/m) to first order in x.

use crate::backend::cpu::blocks::{for_blocks, Reduce, Rows};
use crate::backend::cpu::integrate::Observed;
use crate::backend::cpu::stage::{pass, Booked, CpuStage, StageInput};
use crate::effects::buoyancy::physics::submerged_volume;
use crate::effects::buoyancy::BuoyancyPlan;
use crate::effects::heat_ledger::cpu::HeatLanes;
use crate::model::Model;
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::state::particles::{dof, HeatCauses};

/// The heat the drag took out in a step (J), summed over the elements.
#[derive(Default, Clone, Copy)]
pub struct DragHeat(pub f64);

impl Reduce for DragHeat {
    fn combine(self, o: Self) -> Self {
        DragHeat(self.0 + o.0)
    }
}

/// The stage's pass (`backend::cpu::stage::Build`): the drag's heat is booked apart by an
/// observed step's energies.
pub fn stage(_: &StepPlan) -> Option<Box<dyn CpuStage>> {
    pass(|m, s: &StageInput| {
        let Some(b) = &s.plan.buoyancy else { return Ok(Booked::default()) };
        let DragHeat(heat) = buoyancy(m, b, &s.plan.heat);
        Ok(Booked { observed: Observed { kinetic: 0.0, damping_heat: heat }, ..Booked::default() })
    })
}

/// Adds the buoyant force (and the drag) of this step to the force lane of every element
/// below the level. Runs after the other force stages: the drag reads their sum. With a
/// viscosity and the ledger's damping lane, books the drag's heat in it ([`drag_heat`]) and
/// returns the step's total (the observed step books half of it before the kinetic energy).
pub fn buoyancy(m: &mut Model, plan: &BuoyancyPlan, causes: &HeatCauses) -> DragHeat {
    let dt = m.clock.dt;
    let g = m.settings.gravity;
    let p = &mut m.particles;
    let (pos, vel, radius, mass, fixed) = (&p.pos, &p.vel, &p.radius, &p.mass, &p.fixed);
    let six_pi_mu = 6.0 * std::f64::consts::PI * plan.viscosity;
    let drag = plan.viscosity > 0.0;
    let lanes = (&mut p.force[..], HeatLanes::of(&mut p.heat, causes));
    for_blocks(0..radius.len(), Rows::None, lanes, (), &|range, (force, mut heat), ()| {
        let mut booked = DragHeat::default();
        for i in range.clone() {
            let r = radius[i];
            let v_sub = submerged_volume(pos[i].z, r, plan.level);
            // A killed element is out of the model (kill.rs): its lane stays empty.
            if v_sub == 0.0 || fixed[i] & dof::KILLED != 0 {
                continue;
            }
            let (li, mi) = (i - range.start, mass[i]);
            let f = &mut force[li];
            *f -= g * (plan.density * v_sub);
            if drag {
                let fraction = v_sub / (4.0 / 3.0 * std::f64::consts::PI * r * r * r);
                let x = six_pi_mu * r * fraction * dt / mi;
                let (decay_loss, phi_loss) = drag_factors(x);
                let a = *f / mi + g;
                let fd = -(vel[i] * (decay_loss / dt) + a * phi_loss) * mi;
                *f += fd;
                if let Some(h) = heat.damping_at(li) {
                    let q = drag_heat(fd, vel[i], a, dt, mi, fixed[i]);
                    *h += q;
                    booked.0 += q;
                }
            }
        }
        booked
    })
}

/// The heat the drag F_d takes out of an element in a step (J): −F_d·v̄·dt, v̄ the mean of the
/// half-step velocities before and after the kick, v1 = v + (A + F_d/m)·dt (A the acceleration
/// of every other force), over the components that are not fixed. This is the drag's work as
/// the leapfrog counts every force's (its kinetic energy changes by Σ F·v̄·dt exactly), so
/// mechanical energy + buoyant potential + this heat is conserved as the leapfrog conserves
/// energy. Computed before `integrate`, it is exact without other damping; with MatDEM's
/// viscous or local damping as well, v1 is the velocity the kick would reach without them (an
/// error of the order of their share of the step's change).
#[inline]
pub fn drag_heat(fd: Vec3, v: Vec3, a: Vec3, dt: f64, mass: f64, fixed: u8) -> f64 {
    let v1 = v + (a + fd / mass) * dt;
    let mut q = 0.0;
    for (c, bit) in [dof::X, dof::Y, dof::Z].into_iter().enumerate() {
        if fixed & bit == 0 {
            q -= fd[c] * 0.5 * (v[c] + v1[c]) * dt;
        }
    }
    q
}

/// (1 − e^(−x), 1 − φ) with φ = (1 − e^(−x))/x; 1 − φ by its series where the closed form
/// would cancel (buoyancy.wgsl, whose f32 has no expm1, uses series for both).
#[inline]
pub fn drag_factors(x: f64) -> (f64, f64) {
    let loss = -(-x).exp_m1();
    let phi_loss = if x < 1e-4 { x / 2.0 - x * x / 6.0 + x * x * x / 24.0 } else { 1.0 - loss / x };
    (loss, phi_loss)
}
