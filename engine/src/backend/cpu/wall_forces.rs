//! Stage 3b: particle–wall contacts. Walls are few analytic shapes; each particle tests the
//! walls its mask says are in reach ([`Contacts::wall_near`](crate::state::contacts::Contacts::wall_near),
//! kept with the neighbour rows), so the many particles far from every wall cost one byte.
//! The wall loads are summed per block in a fixed tree order (deterministic).

use super::blocks::{for_blocks, Reduce, Rows};
use crate::model::{Model, NormalKind, TangentialKind};
use crate::physics::contact_law::{
    contact, contact_opened, ContactGeometry, Hertz, Linear, LinearShear, MindlinShear, NormalLaw, PairParams,
    PairState, TangentialLaw,
};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::walls::{Wall, MAX_WALLS};

/// Loads on each wall during one step.
#[derive(Default)]
pub struct WallLoads {
    pub force: [Vec3; MAX_WALLS],
    pub normal: [f64; MAX_WALLS],
    pub stiffness: [f64; MAX_WALLS],
    pub contacts: [u32; MAX_WALLS],
}

impl Reduce for WallLoads {
    fn combine(mut self, o: Self) -> Self {
        for w in 0..MAX_WALLS {
            self.force[w] += o.force[w];
            self.normal[w] += o.normal[w];
            self.stiffness[w] += o.stiffness[w];
            self.contacts[w] += o.contacts[w];
        }
        self
    }
}

/// Adds wall forces to `force` (and `torque`) and stores each wall's load.
pub fn compute_wall_forces(m: &mut Model, plan: &StepPlan) {
    if m.walls.is_empty() {
        return;
    }
    macro_rules! go {
        ($n:ty, $t:ty) => {
            match (plan.dashpot, plan.rotation) {
                (false, false) => wall_loop::<$n, $t, false, false>(m, plan),
                (true, false) => wall_loop::<$n, $t, true, false>(m, plan),
                (false, true) => wall_loop::<$n, $t, false, true>(m, plan),
                (true, true) => wall_loop::<$n, $t, true, true>(m, plan),
            }
        };
    }
    let loads = match (plan.normal, plan.tangential) {
        (NormalKind::Linear, TangentialKind::Linear) => go!(Linear, LinearShear),
        (NormalKind::Linear, TangentialKind::Mindlin) => go!(Linear, MindlinShear),
        (NormalKind::Hertz, TangentialKind::Linear) => go!(Hertz, LinearShear),
        (NormalKind::Hertz, TangentialKind::Mindlin) => go!(Hertz, MindlinShear),
    };
    for (w, wall) in m.walls.iter_mut().enumerate() {
        // Loads on the wall are the reactions of the forces on the particles.
        wall.force = -loads.force[w];
        wall.normal_force = loads.normal[w];
        wall.stiffness = loads.stiffness[w];
        wall.contacts = loads.contacts[w];
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
    let k = Kinematics { vel: &p.vel, mass: &p.mass, ang_vel, dt: clock.dt };
    let (pos, radius, material, walls) = (&p.pos, &p.radius, &p.material, &walls[..]);
    let heat = &mut p.heat;
    let lanes =
        (&mut p.force[..], torque, &mut heat.contact_damping[..], &mut heat.friction[..], &mut heat.wall_work[..]);
    for_blocks(
        0..pos.len(),
        Rows::Stride(nw),
        lanes,
        &mut wall_contacts[..],
        &|range, (force, mut torque, h_damp, h_fric, work), state: &mut [PairState]| {
            let mut loads = WallLoads::default();
            for i in range.clone() {
                let li = i - range.start;
                let (xi, ri) = (pos[i], radius[i]);
                #[cfg(debug_assertions)]
                for (w, wall) in walls.iter().enumerate() {
                    let st = &state[li * nw + w];
                    debug_assert!(
                        near[i] & (1 << w) != 0
                            || (wall.normal_and_distance(&xi).1 >= ri && *st == PairState::default()),
                        "particle {i} touches wall {w} outside its wall mask"
                    );
                }
                // Only the walls in reach (most particles have none), in wall order.
                let mut bits = near[i];
                while bits != 0 {
                    let w = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let wall = &walls[w];
                    let st = &mut state[li * nw + w];
                    let (inward, gap) = wall.normal_and_distance(&xi);
                    let overlap = ri - gap;
                    if overlap <= 0.0 && st.shear == Vec3::zeros() && st.dashpot == 0.0 {
                        // Apart now and the step before.
                        continue;
                    }
                    let params = &plan.wall[w * plan.materials + material[i] as usize];
                    let out = ParticleOut {
                        force: &mut force[li],
                        torque: torque.as_deref_mut().map(|t| &mut t[li]),
                        h_damp: &mut h_damp[li],
                        h_fric: &mut h_fric[li],
                        work: &mut work[li],
                    };
                    wall_contact::<N, T, DASHPOT>(&k, i, ri, wall, w, inward, overlap, params, st, out, &mut loads);
                }
            }
            loads
        },
    )
}

/// What a wall contact reads of the particles.
struct Kinematics<'a> {
    vel: &'a [Vec3],
    mass: &'a [f64],
    ang_vel: Option<&'a [Vec3]>,
    dt: f64,
}

/// One particle's lanes a wall contact adds to.
struct ParticleOut<'a> {
    force: &'a mut Vec3,
    torque: Option<&'a mut Vec3>,
    h_damp: &'a mut f64,
    h_fric: &'a mut f64,
    work: &'a mut f64,
}

/// One particle against one wall, touching (`overlap` > 0) or just come apart. Kept out of
/// line, so that a contact's set-up (square roots of the radius) stays with the contacts
/// instead of being hoisted into every particle the mask lets through.
#[inline(never)]
fn wall_contact<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool>(
    k: &Kinematics<'_>,
    i: usize,
    ri: f64,
    wall: &Wall,
    w: usize,
    inward: Vec3,
    overlap: f64,
    params: &PairParams,
    st: &mut PairState,
    out: ParticleOut<'_>,
    loads: &mut WallLoads,
) {
    let dt = k.dt;
    let nrm = -inward; // from the particle towards the wall
    let v_wall = wall.surface_velocity(&inward);
    let mut v_rel = k.vel[i] - v_wall;
    if let Some(a) = k.ang_vel {
        v_rel += a[i].cross(&(nrm * ri));
    }
    if overlap <= 0.0 {
        // The contact has just opened.
        let (friction, damping) = contact_opened::<T>(params, ri, st, &nrm, v_rel, dt);
        *out.h_fric += friction;
        *out.h_damp += damping;
        return;
    }
    let g = ContactGeometry { n: nrm, overlap, v_rel, r_star: ri, m_star: k.mass[i] };
    let r = contact::<N, T, DASHPOT>(&g, params, st, dt);
    *out.force += r.force;
    if let Some(t) = out.torque {
        *t += (nrm * ri).cross(&r.shear);
    }
    *out.h_damp += r.heat_damping;
    *out.h_fric += r.heat_friction;
    // Work the moving wall does on the particle this step.
    *out.work += r.force.dot(&v_wall) * dt;
    loads.force[w] += r.force;
    loads.normal[w] += r.force.dot(&inward).max(0.0);
    loads.stiffness[w] += r.stiffness;
    loads.contacts[w] += 1;
}
