//! The `wall_forces` stage: particle–wall contacts. Walls are few analytic shapes; each particle
//! tests the walls its mask says are in reach
//! ([`Contacts::wall_near`](crate::state::contacts::Contacts::wall_near), kept with the neighbour
//! rows), so the many particles far from every wall cost one byte. The wall loads are summed per
//! block in a fixed tree order (deterministic).

use super::blocks::{for_blocks, Reduce, Rows};
use crate::effects::heat_ledger::cpu::{book, HeatLanes, WallHeat};
use crate::model::Model;
use crate::physics::contact_law::{
    contact, contact_opened, ContactGeometry, NormalLaw, PairParams, PairState, TangentialLaw,
};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::walls::{Wall, WallPart, MAX_WALLS};

/// Loads on each wall during one step.
#[derive(Default)]
pub struct WallLoads {
    pub force: [Vec3; MAX_WALLS],
    pub normal: [f64; MAX_WALLS],
    pub stiffness: [f64; MAX_WALLS],
    /// Summed normal dashpot coefficients (zero without a dashpot), for servo gains.
    pub damping: [f64; MAX_WALLS],
    pub contacts: [u32; MAX_WALLS],
    /// A cone's axial load on its face and on its rod (zero for other shapes).
    pub tip: [f64; MAX_WALLS],
    pub sleeve: [f64; MAX_WALLS],
}

impl Reduce for WallLoads {
    fn combine(mut self, o: Self) -> Self {
        for w in 0..MAX_WALLS {
            self.force[w] += o.force[w];
            self.normal[w] += o.normal[w];
            self.stiffness[w] += o.stiffness[w];
            self.damping[w] += o.damping[w];
            self.contacts[w] += o.contacts[w];
            self.tip[w] += o.tip[w];
            self.sleeve[w] += o.sleeve[w];
        }
        self
    }
}

/// Adds wall forces to `force` (and `torque`) and stores each wall's load.
pub fn compute_wall_forces(m: &mut Model, plan: &StepPlan) {
    if m.walls.is_empty() {
        return;
    }
    let loads = crate::with_laws!(plan, wall_loop[plan.dashpot, plan.rotation](m, plan));
    store_loads(&mut m.walls, &loads);
}

/// Stores each wall's load of this step.
pub(super) fn store_loads(walls: &mut [Wall], loads: &WallLoads) {
    for (w, wall) in walls.iter_mut().enumerate() {
        // Loads on the wall are the reactions of the forces on the particles.
        wall.force = -loads.force[w];
        wall.normal_force = loads.normal[w];
        wall.stiffness = loads.stiffness[w];
        wall.damping = loads.damping[w];
        wall.contacts = loads.contacts[w];
        wall.tip_force = loads.tip[w];
        wall.sleeve_force = loads.sleeve[w];
    }
}

fn wall_loop<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool>(
    m: &mut Model,
    plan: &StepPlan,
) -> WallLoads {
    let nw = m.walls.len();
    let Model { particles: p, wall_contacts, walls, clock, contacts, .. } = m;
    let near = &contacts.wall_near[..];
    debug_assert_eq!(near.len(), p.pos.len(), "wall mask out of date: rebuild the rows first");
    let (ang_vel, torque) = match &mut p.rotation {
        Some(r) if ROT => (Some(&r.ang_vel[..]), Some(&mut r.torque[..])),
        _ => (None, None),
    };
    let (pos, radius, vel, mass, material) = (&p.pos, &p.radius, &p.vel, &p.mass, &p.material);
    let (walls, dt) = (&walls[..], clock.dt);
    let lanes = (&mut p.force[..], torque, HeatLanes::of(&mut p.heat, &plan.heat));
    for_blocks(
        0..pos.len(),
        Rows::Stride(nw),
        lanes,
        &mut wall_contacts[..],
        &|range, (force, mut torque, mut heat), state: &mut [PairState]| {
            let mut loads = WallLoads::default();
            for i in range.clone() {
                let li = i - range.start;
                let st = &mut state[li * nw..(li + 1) * nw];
                #[cfg(debug_assertions)]
                check_mask(walls, i, near[i], &pos[i], radius[i], st);
                // Most particles have no wall in reach.
                if near[i] == 0 {
                    continue;
                }
                let body = Body {
                    pos: pos[i],
                    radius: radius[i],
                    vel: vel[i],
                    mass: mass[i],
                    ang_vel: ang_vel.map(|a| a[i]),
                    material: material[i],
                };
                let mut out = ParticleOut {
                    force: &mut force[li],
                    torque: torque.as_deref_mut().map(|t| &mut t[li]),
                    heat: heat.walls_at(li),
                };
                particle_walls::<N, T, DASHPOT>(walls, plan, dt, near[i], &body, st, &mut out, &mut loads);
            }
            loads
        },
    )
}

/// Checks that a particle outside its wall mask neither touches the wall nor holds state.
#[cfg(debug_assertions)]
pub(super) fn check_mask(walls: &[Wall], i: usize, near: u8, x: &Vec3, r: f64, state: &[PairState]) {
    for (w, wall) in walls.iter().enumerate() {
        debug_assert!(
            near & (1 << w) != 0 || (wall.normal_and_distance(x).1 >= r && state[w] == PairState::default()),
            "particle {i} touches wall {w} outside its wall mask"
        );
    }
}

/// One particle's contacts with the walls its mask `near` lets through, in wall order;
/// `state` holds its contact state with every wall.
#[inline(always)]
pub(super) fn particle_walls<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool>(
    walls: &[Wall],
    plan: &StepPlan,
    dt: f64,
    near: u8,
    body: &Body,
    state: &mut [PairState],
    out: &mut ParticleOut<'_>,
    loads: &mut WallLoads,
) {
    let mut bits = near;
    while bits != 0 {
        let w = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let wall = &walls[w];
        let st = &mut state[w];
        let (inward, gap, part) = wall.normal_distance_part(&body.pos);
        let overlap = body.radius - gap;
        if overlap <= 0.0 && st.shear == Vec3::zeros() && st.dashpot == 0.0 {
            // Apart now and the step before.
            continue;
        }
        let params = plan.wall_pair(w, body.material);
        let touch = WallTouch { w, inward, overlap, part };
        wall_contact::<N, T, DASHPOT>(body, wall, &touch, params, st, dt, out, loads);
    }
}

/// What a wall contact reads of its particle (ang_vel: rotation only).
pub(super) struct Body {
    pub pos: Vec3,
    pub radius: f64,
    pub vel: Vec3,
    pub mass: f64,
    pub ang_vel: Option<Vec3>,
    pub material: u32,
}

/// One particle's lanes a wall contact adds to.
pub(super) struct ParticleOut<'a> {
    pub force: &'a mut Vec3,
    pub torque: Option<&'a mut Vec3>,
    /// Its ledger entries (those the plan has).
    pub heat: WallHeat<'a>,
}

/// Where a particle touches a wall: the wall's index, the unit normal into the particles'
/// region, the overlap (m) and the part touched.
#[derive(Clone, Copy)]
struct WallTouch {
    w: usize,
    inward: Vec3,
    overlap: f64,
    part: WallPart,
}

/// One particle against one wall, touching (`overlap` > 0) or just come apart. Kept out of
/// line, so that a contact's set-up (square roots of the radius) stays with the contacts
/// instead of being hoisted into every particle the mask lets through.
#[inline(never)]
fn wall_contact<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool>(
    body: &Body,
    wall: &Wall,
    touch: &WallTouch,
    params: &PairParams,
    st: &mut PairState,
    dt: f64,
    out: &mut ParticleOut<'_>,
    loads: &mut WallLoads,
) {
    let WallTouch { w, inward, overlap, part } = *touch;
    let ri = body.radius;
    let nrm = -inward; // from the particle towards the wall
    let v_wall = wall.surface_velocity(&inward);
    let mut v_rel = body.vel - v_wall;
    if let Some(a) = body.ang_vel {
        v_rel += a.cross(&(nrm * ri));
    }
    if overlap <= 0.0 {
        // The contact has just opened.
        let (friction, damping) = contact_opened::<T>(params, ri, st, &nrm, v_rel, dt);
        book(&mut out.heat.friction, friction);
        book(&mut out.heat.damping, damping);
        return;
    }
    let g = ContactGeometry { n: nrm, overlap, v_rel, r_star: ri, m_star: body.mass };
    let r = contact::<N, T, DASHPOT>(&g, params, st, dt);
    *out.force += r.force;
    if let Some(t) = out.torque.as_deref_mut() {
        *t += (nrm * ri).cross(&r.shear);
    }
    book(&mut out.heat.damping, r.heat_damping);
    book(&mut out.heat.friction, r.heat_friction);
    // Work the moving wall does on the particle this step (none by a wall at rest: skipping
    // the zero keeps the lane, which most steps would otherwise fetch from memory for nothing).
    if v_wall != Vec3::zeros() {
        book(&mut out.heat.work, r.force.dot(&v_wall) * dt);
    }
    loads.force[w] += r.force;
    loads.normal[w] += r.force.dot(&inward).max(0.0);
    loads.stiffness[w] += r.stiffness;
    loads.damping[w] += r.damping;
    loads.contacts[w] += 1;
    // A cone's loads by part: the axial component of the force on the wall (the reaction).
    if let (WallPart::Tip | WallPart::Sleeve, Some(axis)) = (part, wall.axis()) {
        let axial = -r.force.dot(&axis);
        match part {
            WallPart::Tip => loads.tip[w] += axial,
            _ => loads.sleeve[w] += axial,
        }
    }
}
