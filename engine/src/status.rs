//! Observation: energies and heat, coordination number, contact forces, unbalanced force,
//! porosity. These run on demand or on sampling steps, never inside the force loops.

use crate::body_potential::BodyFields;
use crate::effects::parallel_bond::physics as parallel_bond;
use crate::model::Model;
use crate::physics::contact_law::{normal_energy, shear_energy, NormalLaw, TangentialLaw};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::state::particles::dof;
use crate::walls::WallShape;
use serde::{Deserialize, Serialize};

// Regions are geometry; statistics and scripts have long named them from here.
pub use crate::geometry::region::Region;

/// Energy account of the model (J). With no damping and no breakage the mechanical sum
/// is constant; otherwise mechanical + heat − wall work − body work − applied work is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Energies {
    pub kinetic: f64,
    pub normal_elastic: f64,
    pub shear_elastic: f64,
    pub gravity: f64,
    /// The water table's buoyant potential Σ −g_z·ρ_f·∫V_sub dz (0 without water;
    /// `body_potential`): ρ_f·|g|·V times the depth of a submerged element's centre.
    #[serde(default)]
    pub buoyancy: f64,
    /// The confining fluid's potential σ3·V, V the volume the membrane encloses over the grains
    /// it touches (0 without confinement; effects/confining_pressure/physics.rs): the
    /// membrane's loads are its gradient while no grain changes cell and the platens stand.
    #[serde(default)]
    pub confining: f64,
    pub heat_damping: f64,
    pub heat_contact_damping: f64,
    pub heat_friction: f64,
    pub heat_breakage: f64,
    pub wall_work: f64,
    /// Work done on the model by changing gravity or the water table between runs
    /// (`body_potential`): the change of the body potential where the elements stood.
    #[serde(default)]
    pub body_work: f64,
    /// Work done on the model by the applied forces and torques (`d.apply_force`,
    /// `d.apply_torque`): Σ F·Δx + T·Δθ over each load's constant stretches
    /// (effects/applied_loads/lanes.rs).
    #[serde(default)]
    pub applied_work: f64,
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
        self.kinetic + self.normal_elastic + self.shear_elastic + self.gravity + self.buoyancy + self.confining
    }

    pub fn heat(&self) -> f64 {
        self.heat_damping + self.heat_contact_damping + self.heat_friction + self.heat_breakage
    }

    /// Mechanical energy plus heat minus the work walls, changes of the body forces and the
    /// applied loads did: constant in a closed system.
    pub fn total(&self) -> f64 {
        self.mechanical() + self.heat() - self.wall_work - self.body_work - self.applied_work
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
    let body = BodyFields::of(m);
    e.gravity = body.gravity_potential(m);
    e.buoyancy = body.buoyant_potential(m);
    e.confining = m.confining_potential();
    e.body_work = m.body_work();
    e.applied_work = m.particles.applied_work();
    let h = &m.particles.heat;
    e.heat_damping = h.damping.iter().sum();
    e.heat_contact_damping = h.contact_damping.iter().sum();
    e.heat_friction = h.friction.iter().sum();
    e.heat_breakage = h.breakage.iter().sum();
    e.wall_work = h.wall_work.iter().sum();
    e
}

fn spring_energies<N: NormalLaw, T: TangentialLaw>(m: &Model, plan: &StepPlan) -> Energies {
    let (p, c, sep) = (&m.particles, &m.contacts, m.separations());
    let mut e = Energies::default();
    for i in 0..p.len() {
        for k in c.row(i) {
            let j = c.other[k] as usize;
            if j < i {
                continue;
            }
            let st = &c.state[k];
            let overlap = p.radius[i] + p.radius[j] - sep.between(&p.pos, i, j).norm();
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
            // A killed element holds no wall contact (kill.rs).
            if overlap > 0.0 && p.fixed[i] & dof::KILLED == 0 {
                let pp = plan.wall_pair(w, p.material[i]);
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
    // A clump's members count as its body, not one by one.
    let own = |i: &usize| p.fixed[*i] & crate::state::particles::dof::CLUMPED == 0;
    let mut ke: f64 = (0..p.len()).filter(own).map(|i| 0.5 * p.mass[i] * p.vel[i].norm_squared()).sum();
    if let Some(r) = &p.rotation {
        ke += (0..p.len()).filter(own).map(|i| 0.5 * p.inertia(i) * r.ang_vel[i].norm_squared()).sum::<f64>();
    }
    ke + m.clumps.bodies.iter().map(crate::effects::clumps::lanes::Body::kinetic_energy).sum::<f64>()
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
    let (p, c, sep) = (&m.particles, &m.contacts, m.separations());
    let mut s = ContactStats::default();
    let mut f_sum = 0.0;
    let mut touching = 0usize;
    for i in 0..p.len() {
        for k in c.row(i) {
            let j = c.other[k] as usize;
            if j < i {
                continue;
            }
            let overlap = p.radius[i] + p.radius[j] - sep.between(&p.pos, i, j).norm();
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
                f_sum += plan.normal.force(pp, r_star, overlap);
            }
        }
    }
    // Killed elements are out of the model (kill.rs): not counted.
    let n = (p.len() - m.killed_count()).max(1) as f64;
    s.coordination = 2.0 * s.contacts as f64 / n;
    s.mean_normal_force = if touching > 0 { f_sum / touching as f64 } else { 0.0 };
    let g = m.settings.gravity;
    let net: f64 = (0..p.len()).filter(|&i| m.is_free(i)).map(|i| (p.force[i] + g * p.mass[i]).norm()).sum::<f64>() / n;
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

/// Porosity of a region by volume fraction: 1 − (the volume the spheres share with it) / its
/// volume. Spheres cut by the region's faces count by the part inside (exact intersection
/// volumes, [`crate::geometry::sphere_box`]), not whole or not at all by their centres; in a
/// periodic cell, with the parts that reach the region through the faces (for a region within
/// the cell). A 2D model's is by area in its plane ([`crate::planar::porosity::porosity_by_area`]).
pub fn porosity(m: &Model, region: &Region) -> f64 {
    if m.planar().is_some() {
        return crate::planar::porosity::porosity_by_area(m, region);
    }
    let p = &m.particles;
    // In a periodic cell a sphere reaching out through a face comes in through the other.
    let shifts = m.effects.periodic.cell.map_or_else(|| vec![Vec3::zeros()], |c| c.image_shifts());
    let solid: f64 = (0..p.len())
        .filter(|&i| !m.is_killed(i))
        .map(|i| shifts.iter().map(|s| region.shared_volume(p.pos[i] + s, p.radius[i])).sum::<f64>())
        .sum();
    let v = region.volume();
    if v > 0.0 {
        1.0 - solid / v
    } else {
        f64::NAN
    }
}

/// The coordination number of the particles that carry load (Thornton 2000's mechanical
/// coordination number, the rule MatDEM users quote): rattlers — particles with fewer than
/// two contacts — are left out, and so are their contacts, repeatedly, until every particle
/// left has two or more. A contact is a touching or bonded pair; a wall touching a particle
/// counts towards that particle's two (a grain pressed against the ring by one neighbour
/// carries load), but the number itself counts particle–particle contacts only, each for
/// both its ends, over the particles left.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Coordination {
    /// Mean contacts per load-carrying particle.
    pub coordination: f64,
    /// Particles left out as rattlers.
    pub rattlers: usize,
    /// Particles counted.
    pub counted: usize,
}

pub fn coordination_without_rattlers(m: &Model) -> Coordination {
    let (p, c, sep) = (&m.particles, &m.contacts, m.separations());
    let n = p.len();
    let touching = |i: usize, k: usize| {
        let j = c.other[k] as usize;
        c.state[k].bonded || sep.between(&p.pos, i, j).norm() < p.radius[i] + p.radius[j]
    };
    let rows = c.row_start.len().saturating_sub(1).min(n);
    let mut count: Vec<usize> = (0..n)
        .map(|i| {
            let walls = m.walls.iter().filter(|w| w.normal_and_distance(&p.pos[i]).1 < p.radius[i]).count();
            let pairs = if i < rows { c.row(i).filter(|&k| touching(i, k)).count() } else { 0 };
            walls + pairs
        })
        .collect();
    // Killed elements (kill.rs) are neither counted nor rattlers: they are out of the model.
    let mut rattler: Vec<bool> = (0..n).map(|i| m.is_killed(i)).collect();
    let killed = rattler.iter().filter(|k| **k).count();
    let mut queue: Vec<usize> = (0..n).filter(|&i| count[i] < 2).collect();
    while let Some(i) = queue.pop() {
        if rattler[i] {
            continue;
        }
        rattler[i] = true;
        if i < rows {
            for k in c.row(i) {
                let j = c.other[k] as usize;
                if !rattler[j] && touching(i, k) {
                    count[j] -= 1;
                    if count[j] < 2 {
                        queue.push(j);
                    }
                }
            }
        }
    }
    let counted = rattler.iter().filter(|r| !**r).count();
    let contacts: usize = (0..rows)
        .filter(|&i| !rattler[i])
        .map(|i| c.row(i).filter(|&k| !rattler[c.other[k] as usize] && touching(i, k)).count())
        .sum();
    Coordination {
        coordination: if counted > 0 { contacts as f64 / counted as f64 } else { 0.0 },
        rattlers: n - killed - counted,
        counted,
    }
}

/// The stress on wall `w` (Pa, compression > 0). A plane's is its normal force over its
/// area; a ring's (a vertical cylinder) is its radial force over the part of its side the
/// particles load: 2πR times the height between the lowest and highest point of the
/// particles touching it, not the nominal height it was built with (a ring filled to half
/// its height would otherwise read half the stress).
pub fn wall_stress(m: &Model, w: usize) -> f64 {
    let wall = &m.walls[w];
    let WallShape::Cylinder { radius, .. } = wall.shape else {
        return wall.stress();
    };
    let p = &m.particles;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..p.len() {
        if wall.normal_and_distance(&p.pos[i]).1 < p.radius[i] && !m.is_killed(i) {
            lo = lo.min(p.pos[i].z - p.radius[i]);
            hi = hi.max(p.pos[i].z + p.radius[i]);
        }
    }
    let area = 2.0 * std::f64::consts::PI * radius * (hi - lo);
    if area > 0.0 {
        wall.normal_force / area
    } else {
        0.0
    }
}

/// Sum of the normal contact forces each particle carries from other particles (N): the
/// load a grain transmits, for "mean force per size class".
pub fn contact_loads(m: &Model, plan: &StepPlan) -> Vec<f64> {
    let (p, c, sep) = (&m.particles, &m.contacts, m.separations());
    (0..p.len())
        .map(|i| {
            c.row(i)
                .map(|k| {
                    let j = c.other[k] as usize;
                    let overlap = p.radius[i] + p.radius[j] - sep.between(&p.pos, i, j).norm();
                    if overlap <= 0.0 {
                        return 0.0;
                    }
                    let pp = plan.pair(p.material[i], p.material[j]);
                    let r_star = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
                    plan.normal.force(pp, r_star, overlap)
                })
                .sum()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::Material;
    use crate::walls::Wall;
    use std::f64::consts::PI;

    #[test]
    fn a_ring_s_stress_is_its_force_over_the_height_its_particles_load() {
        let (ring_r, r) = (0.01, 0.0005);
        let mut m = Model::new();
        m.add_material(Material::from_micro("m", 2600.0, 1e5, 4e4, 0.0, 0.0, 0.3, r).unwrap()).unwrap();
        // Nominal height 0.05 m; three grains press on the ring between z = 0.0005 and 0.0035,
        // one more sits in the middle, touching nothing.
        m.add_wall(Wall::cylinder("ring", Vec3::zeros(), ring_r, 2.0 * PI * ring_r * 0.05).unwrap()).unwrap();
        for z in [0.001, 0.002, 0.003] {
            m.add_particle(Vec3::new(ring_r - 0.9 * r, 0.0, z), r, 0).unwrap();
        }
        m.add_particle(Vec3::new(0.0, 0.0, 0.02), r, 0).unwrap();
        m.walls[0].normal_force = 10.0;
        let loaded = 10.0 / (2.0 * PI * ring_r * 0.003);
        assert!((wall_stress(&m, 0) / loaded - 1.0).abs() < 1e-12, "{} vs {loaded}", wall_stress(&m, 0));
        assert!((m.walls[0].stress() - loaded * 0.003 / 0.05).abs() < 1e-9 * loaded, "the nominal reading");
        // A plane's stress is its force over its area, as before.
        m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 4e-4).unwrap()).unwrap();
        m.walls[1].normal_force = 2.0;
        assert_eq!(wall_stress(&m, 1), 2.0 / 4e-4);
    }

    #[test]
    fn a_segment_counts_by_its_share_inside_each_region() {
        let (a, b) = (Vec3::new(-1.0, 0.5, 0.5), Vec3::new(1.0, 0.5, 0.5));
        let cube = Region::Box { lo: Vec3::zeros(), hi: Vec3::repeat(1.0) };
        assert!((cube.segment_share(a, b) - 0.5).abs() < 1e-15);
        assert_eq!(cube.segment_share(a + Vec3::z() * 2.0, b + Vec3::z() * 2.0), 0.0);
        let ball = Region::Sphere { center: Vec3::new(0.0, 0.5, 0.5), radius: 0.5 };
        assert!((ball.segment_share(a, b) - 0.5).abs() < 1e-15);
        let can = Region::Cylinder { center: Vec3::new(0.0, 0.5, 0.0), radius: 0.25, z0: 0.0, z1: 1.0 };
        assert!((can.segment_share(a, b) - 0.25).abs() < 1e-15);
        // A vertical segment on the cylinder's axis: inside between z0 and z1.
        assert!((can.segment_share(Vec3::new(0.0, 0.5, -1.0), Vec3::new(0.0, 0.5, 1.0)) - 0.5).abs() < 1e-15);
    }
}
