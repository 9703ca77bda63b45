//! The CPU reference backend (f64, rayon). One step is a sequence of named stages; each
//! has a file of its own and, on the GPU, a kernel of the same name.

pub mod blocks;
pub mod contact_forces;
pub mod integrate;
pub mod neighbours;
pub mod wall_forces;

use crate::model::{Breakage, Model};
use crate::plan::StepPlan;
use crate::status::{potential_energies, Energies};
use contact_forces::compute_contact_forces;
use integrate::integrate;
use wall_forces::compute_wall_forces;

/// Per-run derived data: the plan and each particle's viscous damping coefficient.
pub struct CpuBackend {
    pub plan: StepPlan,
    /// c_i = 2·ζ·√(m_i·k_i); empty when viscous damping is off.
    damping_c: Vec<f64>,
}

impl CpuBackend {
    pub fn prepare(m: &Model) -> Self {
        let plan = StepPlan::build(m);
        let damping_c = if plan.damping > 0.0 {
            (0..m.len())
                .map(|i| 2.0 * plan.damping * (m.particles.mass[i] * m.element_stiffness(i)).sqrt())
                .collect()
        } else {
            Vec::new()
        };
        CpuBackend { plan, damping_c }
    }

    /// Advances the model by one step. Returns the energies at the start of the step's
    /// integer time when `observe`.
    ///
    /// Order follows the physics: walls move first so contacts see this step's walls;
    /// forces are complete before integration.
    pub fn step(&mut self, m: &mut Model, observe: bool) -> Option<Energies> {
        let dt = m.clock.dt;
        for w in &mut m.walls {
            w.advance(dt);
        }
        if neighbours::is_stale(&m.contacts, &m.particles.pos) {
            neighbours::rebuild(m);
        }
        let breaks = compute_contact_forces(m, &self.plan);
        compute_wall_forces(m, &self.plan);
        for (i, j, kind) in breaks.0 {
            m.breakages.push(Breakage { step: m.clock.step, time: m.clock.time, i, j, kind });
        }
        let mut energies = observe.then(|| potential_energies(m, &self.plan));
        let ke = integrate(m, &self.damping_c, observe);
        if let Some(e) = &mut energies {
            e.kinetic = ke;
        }
        m.clock.step += 1;
        m.clock.time += dt;
        energies
    }
}
