//! Observation: energies and heat, coordination number, contact forces, unbalanced force,
//! porosity. These run on demand or on sampling steps, never inside the force loops.

use crate::model::{Model, NormalKind};
use crate::physics::contact_law::{normal_energy, shear_energy, Hertz, Linear, NormalLaw, TangentialLaw};
use crate::physics::parallel_bond;
use crate::physics::Vec3;
use crate::plan::StepPlan;
use serde::{Deserialize, Serialize};

/// Energy account of the model (J). With no damping and no breakage the mechanical sum
/// is constant; otherwise mechanical + heat − wall work is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Energies {
    pub kinetic: f64,
    pub normal_elastic: f64,
    pub shear_elastic: f64,
    pub gravity: f64,
    pub heat_damping: f64,
    pub heat_contact_damping: f64,
    pub heat_friction: f64,
    pub heat_breakage: f64,
    pub wall_work: f64,
}

/// One energy sample of a run: the account at the start of step `step` (time `time`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergySample {
    pub step: u64,
    pub time: f64,
    pub energies: Energies,
}

impl Energies {
    pub fn mechanical(&self) -> f64 {
        self.kinetic + self.normal_elastic + self.shear_elastic + self.gravity
    }

    pub fn heat(&self) -> f64 {
        self.heat_damping + self.heat_contact_damping + self.heat_friction + self.heat_breakage
    }

    /// Mechanical energy plus heat minus the work walls did: constant in a closed system.
    pub fn total(&self) -> f64 {
        self.mechanical() + self.heat() - self.wall_work
    }
}

/// Potential energies and heat at the current positions; `kinetic` is left for the caller
/// (the integrator knows the velocity at the integer step).
pub fn potential_energies(m: &Model, plan: &StepPlan) -> Energies {
    let mut e = crate::with_laws!(plan, spring_energies[](m, plan));
    if plan.has(crate::plan::Stage::ParallelBond) {
        // The parallel bonds' springs: normal and bending with the normal springs, shear and
        // twisting with the shear springs.
        let (normal, shear) = parallel_bond_energies(m);
        e.normal_elastic += normal;
        e.shear_elastic += shear;
    }
    let p = &m.particles;
    let g = m.settings.gravity;
    e.gravity = -(0..p.len()).map(|i| p.mass[i] * g.dot(&p.pos[i])).sum::<f64>();
    let h = &p.heat;
    e.heat_damping = h.damping.iter().sum();
    e.heat_contact_damping = h.contact_damping.iter().sum();
    e.heat_friction = h.friction.iter().sum();
    e.heat_breakage = h.breakage.iter().sum();
    e.wall_work = h.wall_work.iter().sum();
    e
}

fn spring_energies<N: NormalLaw, T: TangentialLaw>(m: &Model, plan: &StepPlan) -> Energies {
    let (p, c) = (&m.particles, &m.contacts);
    let mut e = Energies::default();
    for i in 0..p.len() {
        for k in c.row(i) {
            let j = c.other[k] as usize;
            if j < i {
                continue;
            }
            let st = &c.state[k];
            let overlap = p.radius[i] + p.radius[j] - (p.pos[j] - p.pos[i]).norm();
            if overlap <= 0.0 && !st.bonded {
                continue;
            }
            let pp = plan.pair(p.material[i], p.material[j]);
            let r_star = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
            e.normal_elastic += normal_energy::<N>(pp, r_star, overlap, st.bonded);
            e.shear_elastic += shear_energy(st.shear, T::stiffness(pp, r_star, overlap));
        }
        for (w, wall) in m.walls.iter().enumerate() {
            let (_, gap) = wall.normal_and_distance(&p.pos[i]);
            let overlap = p.radius[i] - gap;
            if overlap > 0.0 {
                let pp = &plan.wall[w * plan.materials + p.material[i] as usize];
                e.normal_elastic += N::energy(pp, p.radius[i], overlap);
                let st = &m.wall_contacts[i * m.walls.len() + w];
                e.shear_elastic += shear_energy(st.shear, T::stiffness(pp, p.radius[i], overlap));
            }
        }
    }
    e
}

/// Elastic energy the intact parallel bonds hold (J), as (normal + bending, shear + twisting);
/// each bond counted once.
pub fn parallel_bond_energies(m: &Model) -> (f64, f64) {
    let (p, b) = (&m.particles, &m.parallel_bonds);
    let Some(params) = &b.params else { return (0.0, 0.0) };
    let (mut normal, mut shear) = (0.0, 0.0);
    for i in 0..b.row_start.len().saturating_sub(1) {
        for e in b.row(i) {
            let j = b.other[e] as usize;
            if j > i && b.state[e].intact() {
                let (en, es) = parallel_bond::energy(&b.state[e], &params.section(p.radius[i], p.radius[j]));
                normal += en;
                shear += es;
            }
        }
    }
    (normal, shear)
}

/// Kinetic energy from the stored (half-step) velocities (J).
pub fn kinetic_energy(m: &Model) -> f64 {
    let p = &m.particles;
    let mut ke: f64 = (0..p.len()).map(|i| 0.5 * p.mass[i] * p.vel[i].norm_squared()).sum();
    if let Some(r) = &p.rotation {
        ke += (0..p.len()).map(|i| 0.5 * p.inertia(i) * r.ang_vel[i].norm_squared()).sum::<f64>();
    }
    ke
}

/// Contact statistics between particles.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ContactStats {
    /// Touching or bonded pairs.
    pub contacts: usize,
    pub bonds: usize,
    /// Mean contacts per particle, MatDEM's Nc/Np (each contact counted for both ends).
    pub coordination: f64,
    /// Mean magnitude of the normal force over touching pairs (N).
    pub mean_normal_force: f64,
    /// Mean |net force| over mean contact force; near 0 at equilibrium.
    pub unbalanced_ratio: f64,
}

pub fn contact_stats(m: &Model, plan: &StepPlan) -> ContactStats {
    let (p, c) = (&m.particles, &m.contacts);
    let mut s = ContactStats::default();
    let mut f_sum = 0.0;
    let mut touching = 0usize;
    for i in 0..p.len() {
        for k in c.row(i) {
            let j = c.other[k] as usize;
            if j < i {
                continue;
            }
            let overlap = p.radius[i] + p.radius[j] - (p.pos[j] - p.pos[i]).norm();
            let bonded = c.state[k].bonded;
            if bonded {
                s.bonds += 1;
            }
            if overlap > 0.0 || bonded {
                s.contacts += 1;
            }
            if overlap > 0.0 {
                touching += 1;
                let pp = plan.pair(p.material[i], p.material[j]);
                let r_star = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
                f_sum += match plan.normal {
                    NormalKind::Linear => Linear::force(pp, r_star, overlap),
                    NormalKind::Hertz => Hertz::force(pp, r_star, overlap),
                };
            }
        }
    }
    let n = p.len().max(1) as f64;
    s.coordination = 2.0 * s.contacts as f64 / n;
    s.mean_normal_force = if touching > 0 { f_sum / touching as f64 } else { 0.0 };
    let g = m.settings.gravity;
    let net: f64 =
        (0..p.len()).filter(|&i| p.fixed[i] == 0).map(|i| (p.force[i] + g * p.mass[i]).norm()).sum::<f64>() / n;
    // With no contacts anything moving is unbalanced (free fall): report infinity, not 0.
    s.unbalanced_ratio = if s.mean_normal_force > 0.0 {
        net / s.mean_normal_force
    } else if net > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    s
}

/// A region for porosity and void ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region {
    Box {
        lo: Vec3,
        hi: Vec3,
    },
    /// Vertical cylinder between `z0` and `z1`.
    Cylinder {
        center: Vec3,
        radius: f64,
        z0: f64,
        z1: f64,
    },
}

impl Region {
    pub fn contains(&self, x: &Vec3) -> bool {
        match self {
            Region::Box { lo, hi } => (0..3).all(|k| x[k] >= lo[k] && x[k] <= hi[k]),
            Region::Cylinder { center, radius, z0, z1 } => {
                let (dx, dy) = (x.x - center.x, x.y - center.y);
                dx * dx + dy * dy <= radius * radius && x.z >= *z0 && x.z <= *z1
            }
        }
    }

    pub fn volume(&self) -> f64 {
        match self {
            Region::Box { lo, hi } => (hi - lo).iter().map(|d| d.max(0.0)).product(),
            Region::Cylinder { radius, z0, z1, .. } => std::f64::consts::PI * radius * radius * (z1 - z0).max(0.0),
        }
    }
}

/// Porosity of a region, counting each sphere whose centre lies inside it whole.
pub fn porosity(m: &Model, region: &Region) -> f64 {
    let p = &m.particles;
    let solid: f64 = (0..p.len())
        .filter(|&i| region.contains(&p.pos[i]))
        .map(|i| 4.0 / 3.0 * std::f64::consts::PI * p.radius[i].powi(3))
        .sum();
    let v = region.volume();
    if v > 0.0 {
        1.0 - solid / v
    } else {
        f64::NAN
    }
}

/// Sum of the normal contact forces each particle carries from other particles (N): the
/// load a grain transmits, for "mean force per size class".
pub fn contact_loads(m: &Model, plan: &StepPlan) -> Vec<f64> {
    let (p, c) = (&m.particles, &m.contacts);
    (0..p.len())
        .map(|i| {
            c.row(i)
                .map(|k| {
                    let j = c.other[k] as usize;
                    let overlap = p.radius[i] + p.radius[j] - (p.pos[j] - p.pos[i]).norm();
                    if overlap <= 0.0 {
                        return 0.0;
                    }
                    let pp = plan.pair(p.material[i], p.material[j]);
                    let r_star = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
                    match plan.normal {
                        NormalKind::Linear => Linear::force(pp, r_star, overlap),
                        NormalKind::Hertz => Hertz::force(pp, r_star, overlap),
                    }
                })
                .sum()
        })
        .collect()
}
