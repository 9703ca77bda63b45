//! The contact list: one row per contact or bond of the model as it stands — both bodies (an
//! element and another element, or a wall), the contact point, the unit normal, the overlap,
//! the normal and shear forces, and the bond's state — and each element's sums of those
//! forces and their torques.
//!
//! Each contact is evaluated by the contact law the steps use
//! ([`contact`](crate::physics::contact_law::contact), monomorphised for the plan's laws as the
//! backends' loops are), at the positions and velocities the model holds and with the shear
//! spring it stores, over a time step of zero: the spring is carried into the present tangent
//! plane and capped, the dashpots act at the present relative velocity, and nothing is
//! advanced or broken (the law runs on a copy of the pair's state). So the forces are those
//! the model holds now; they differ from the last step's force lane (`Particles::force`,
//! taken before that step moved the elements) by one step's motion.
//!
//! Not in the list: the `parallel_bond` stage's beams, rolling resistance torques and the
//! pore fluid's or the water table's forces, which act beside the contacts.

use crate::model::Model;
use crate::physics::contact_law::{contact, BreakKind, ContactGeometry, NormalLaw, PairState, TangentialLaw};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use std::collections::HashMap;

/// The other body of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Other {
    /// Another element, by id (always above the row's `i`).
    Element(u32),
    /// A wall, by its index in `Model::walls`.
    Wall(usize),
}

/// A contact's bond.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bond {
    /// The pair was never bonded (or a wall contact).
    None,
    /// Bonded and intact.
    Intact,
    /// The bond broke (recorded in `Model::breakages`), in tension or in shear.
    Broken(BreakKind),
}

impl Bond {
    /// The bond in a word: `none`, `intact`, `broken_tension`, `broken_shear`.
    pub fn name(self) -> &'static str {
        match self {
            Bond::None => "none",
            Bond::Intact => "intact",
            Bond::Broken(BreakKind::Tension) => "broken_tension",
            Bond::Broken(BreakKind::Shear) => "broken_shear",
        }
    }
}

/// One contact (touching or bonded pair, or an element touching a wall), or a broken bond.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactRow {
    /// The element (the lower id of a pair).
    pub i: u32,
    pub other: Other,
    /// The contact point (m): the middle of the overlap between two elements, the point on
    /// the wall's surface nearest the element's centre for a wall.
    pub point: Vec3,
    /// Unit normal from `i` towards the other body.
    pub normal: Vec3,
    /// Overlap (m): positive in compression, negative for a bonded pair pulled apart.
    pub overlap: f64,
    /// Branch vector (m): from `i`'s centre to the other element's, or to the contact point
    /// on a wall.
    pub branch: Vec3,
    /// Normal force, elastic and dashpot (N), positive in compression, negative for a bond
    /// in tension.
    pub normal_force: f64,
    /// Tangential force on `i` (N): the shear spring, and the tangential dashpot of a damped
    /// law.
    pub shear_force: Vec3,
    /// The whole force on `i` (N): `shear_force − normal·normal_force`; the other body feels
    /// its opposite.
    pub force: Vec3,
    pub bond: Bond,
}

impl ContactRow {
    /// The row of elements `i` (at `xi`, radius `ri`) and `j` (branch vector `d` from i to j,
    /// radius `rj`), its forces zero until the law sets them: the contact point midway
    /// through the overlap along the unit normal.
    fn between(i: usize, j: usize, xi: Vec3, d: Vec3, ri: f64, rj: f64, bond: Bond) -> Self {
        let dist = d.norm();
        let normal = if dist > 0.0 { d / dist } else { Vec3::z() };
        let overlap = ri + rj - dist;
        ContactRow {
            i: i as u32,
            other: Other::Element(j as u32),
            point: xi + normal * (ri - 0.5 * overlap),
            normal,
            overlap,
            branch: d,
            normal_force: 0.0,
            shear_force: Vec3::zeros(),
            force: Vec3::zeros(),
            bond,
        }
    }

    /// Whether the row carries force: a touching pair, an intact bond or a wall contact (a
    /// broken bond whose elements have come apart does not).
    pub fn is_active(&self) -> bool {
        self.overlap > 0.0 || self.bond == Bond::Intact
    }

    /// The other element's id, if the other body is an element.
    pub fn j(&self) -> Option<u32> {
        match self.other {
            Other::Element(j) => Some(j),
            Other::Wall(_) => None,
        }
    }
}

/// The model's contacts, ordered by `i`, then the other elements by id, then the walls; and
/// each element's sums.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactList {
    pub rows: Vec<ContactRow>,
    /// Sum of the contact forces on each element (N), walls included.
    pub force: Vec<Vec3>,
    /// Sum of the torques of the contacts' tangential forces about each element's centre
    /// (N·m): (r·n) × F_t, whether or not rotation is simulated.
    pub torque: Vec<Vec3>,
}

/// Evaluates every contact of `m` with the laws of `plan` (see the module's docs). The rows
/// must cover the current positions (`Simulation::contact_list` rebuilds them first).
pub fn contact_list(m: &Model, plan: &StepPlan) -> ContactList {
    crate::with_laws!(plan, evaluate[plan.dashpot](m, plan))
}

fn evaluate<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool>(m: &Model, plan: &StepPlan) -> ContactList {
    let (p, c) = (&m.particles, &m.contacts);
    let n = p.len();
    let ang = p.rotation.as_ref().map(|r| &r.ang_vel[..]);
    let w_of = |i: usize| ang.map_or(Vec3::zeros(), |w| w[i]);
    // The last break of each pair (a pair bonded again may break twice), by its lower id.
    let broken: HashMap<(u32, u32), BreakKind> = m.breakages.iter().map(|b| ((b.i, b.j), b.kind)).collect();
    let mut broken_of: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &(i, j) in broken.keys() {
        if (i as usize) < n {
            broken_of[i as usize].push(j);
        }
    }
    broken_of.iter_mut().for_each(|v| v.sort_unstable());
    let mut out = ContactList { rows: Vec::new(), force: vec![Vec3::zeros(); n], torque: vec![Vec3::zeros(); n] };
    let rows = c.row_start.len().saturating_sub(1).min(n);
    let nw = m.walls.len();
    for i in 0..n {
        if m.is_killed(i) {
            continue;
        }
        let (xi, ri, vi, wi) = (p.pos[i], p.radius[i], p.vel[i], w_of(i));
        let mut seen_broken = Vec::new();
        if i < rows {
            for k in c.row(i) {
                let j = c.other[k] as usize;
                if j <= i || m.is_killed(j) {
                    continue;
                }
                let st = c.state[k];
                let d = m.separation(i, j);
                let rj = p.radius[j];
                let (touch, dist) = (ri + rj, d.norm());
                let key = (i as u32, j as u32);
                let broke = broken.get(&key).copied();
                if !st.bonded && dist >= touch && broke.is_none() {
                    continue;
                }
                if broke.is_some() {
                    seen_broken.push(j as u32);
                }
                let bond = if st.bonded { Bond::Intact } else { broke.map_or(Bond::None, Bond::Broken) };
                let mut row = ContactRow::between(i, j, xi, d, ri, rj, bond);
                let (nrm, overlap) = (row.normal, row.overlap);
                if st.bonded || overlap > 0.0 {
                    let mut v_rel = vi - p.vel[j];
                    if ang.is_some() {
                        v_rel += wi.cross(&(nrm * ri)) - w_of(j).cross(&(nrm * -rj));
                    }
                    let (mi, mj) = (p.mass[i], p.mass[j]);
                    let g = ContactGeometry {
                        n: nrm,
                        overlap,
                        v_rel,
                        r_star: ri * rj / touch,
                        m_star: mi * mj / (mi + mj),
                    };
                    let pp = plan.pair(p.material[i], p.material[j]);
                    let r = contact::<N, T, DASHPOT>(&g, pp, &mut st.clone(), 0.0);
                    row.normal_force = r.normal_force;
                    row.shear_force = r.shear;
                    row.force = r.force;
                    out.force[i] += r.force;
                    out.force[j] -= r.force;
                    // (n·r_i) × F_t on i; from j, (−n·r_j) × (−F_t).
                    out.torque[i] += (nrm * ri).cross(&r.shear);
                    out.torque[j] += (nrm * rj).cross(&r.shear);
                }
                out.rows.push(row);
            }
        }
        // Broken bonds whose pair has left the rows (its elements far apart): listed too.
        for &bj in &broken_of[i] {
            let j = bj as usize;
            if seen_broken.contains(&bj) || j >= n || m.is_killed(j) {
                continue;
            }
            let kind = broken[&(i as u32, bj)];
            out.rows.push(ContactRow::between(i, j, xi, m.separation(i, j), ri, p.radius[j], Bond::Broken(kind)));
        }
        for (w, wall) in m.walls.iter().enumerate() {
            let (inward, gap, _) = wall.normal_distance_part(&xi);
            let overlap = ri - gap;
            if overlap <= 0.0 {
                continue;
            }
            let nrm = -inward;
            let mut v_rel = vi - wall.surface_velocity(&inward);
            if ang.is_some() {
                v_rel += wi.cross(&(nrm * ri));
            }
            let st: PairState = m.wall_contacts.get(i * nw + w).copied().unwrap_or_default();
            let g = ContactGeometry { n: nrm, overlap, v_rel, r_star: ri, m_star: p.mass[i] };
            let params = plan.wall_pair(w, p.material[i]);
            let r = contact::<N, T, DASHPOT>(&g, params, &mut st.clone(), 0.0);
            out.force[i] += r.force;
            out.torque[i] += (nrm * ri).cross(&r.shear);
            out.rows.push(ContactRow {
                i: i as u32,
                other: Other::Wall(w),
                point: xi + nrm * gap,
                normal: nrm,
                overlap,
                branch: nrm * gap,
                normal_force: r.normal_force,
                shear_force: r.shear,
                force: r.force,
                bond: Bond::None,
            });
        }
    }
    out
}
