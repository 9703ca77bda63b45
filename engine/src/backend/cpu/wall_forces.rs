//! Stage 3b: particle–wall contacts. Walls are few analytic shapes, so each particle tests
//! every wall; the wall loads are summed per block in a fixed tree order (deterministic).

use super::blocks::{for_blocks, Reduce, Rows};
use crate::model::{Model, NormalKind, TangentialKind};
use crate::physics::contact_law::{
    contact, contact_opened, ContactGeometry, Hertz, Linear, LinearShear, MindlinShear, NormalLaw, PairState,
    TangentialLaw,
};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::walls::MAX_WALLS;

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
    let dt = m.clock.dt;
    let nw = m.walls.len();
    let Model { particles: p, wall_contacts, walls, .. } = m;
    let walls = &walls[..];
    let (pos, vel, radius, mass, material) = (&p.pos, &p.vel, &p.radius, &p.mass, &p.material);
    let (ang_vel, torque) = match &mut p.rotation {
        Some(r) if ROT => (Some(&r.ang_vel[..]), Some(&mut r.torque[..])),
        _ => (None, None),
    };
    let heat = &mut p.heat;
    let lanes = (
        &mut p.force[..],
        torque,
        &mut heat.contact_damping[..],
        &mut heat.friction[..],
        &mut heat.wall_work[..],
    );
    for_blocks(
        0..p.pos.len(),
        Rows::Stride(nw),
        lanes,
        &mut wall_contacts[..],
        &|range, (force, mut torque, h_damp, h_fric, work), state: &mut [PairState]| {
            let mut loads = WallLoads::default();
            for i in range.clone() {
                let li = i - range.start;
                let (xi, ri) = (pos[i], radius[i]);
                for (w, wall) in walls.iter().enumerate() {
                    let st = &mut state[li * nw + w];
                    let (inward, gap) = wall.normal_and_distance(&xi);
                    let overlap = ri - gap;
                    let params = &plan.wall[w * plan.materials + material[i] as usize];
                    if overlap <= 0.0 {
                        if st.shear != Vec3::zeros() || st.dashpot != 0.0 {
                            // The contact has just opened.
                            let nrm = -inward;
                            let mut v_rel = vel[i] - wall.surface_velocity(&inward);
                            if ROT {
                                let wi = ang_vel.map_or(Vec3::zeros(), |a| a[i]);
                                v_rel += wi.cross(&(nrm * ri));
                            }
                            let (friction, damping) = contact_opened::<T>(params, ri, st, &nrm, v_rel, dt);
                            h_fric[li] += friction;
                            h_damp[li] += damping;
                        }
                        continue;
                    }
                    let nrm = -inward; // from the particle towards the wall
                    let v_wall = wall.surface_velocity(&inward);
                    let mut v_rel = vel[i] - v_wall;
                    if ROT {
                        let wi = ang_vel.map_or(Vec3::zeros(), |a| a[i]);
                        v_rel += wi.cross(&(nrm * ri));
                    }
                    let g = ContactGeometry { n: nrm, overlap, v_rel, r_star: ri, m_star: mass[i] };
                    let r = contact::<N, T, DASHPOT>(&g, params, st, dt);
                    force[li] += r.force;
                    if let Some(tq) = torque.as_deref_mut() {
                        tq[li] += (nrm * ri).cross(&r.shear);
                    }
                    h_damp[li] += r.heat_damping;
                    h_fric[li] += r.heat_friction;
                    // Work the moving wall does on the particle this step.
                    work[li] += r.force.dot(&v_wall) * dt;
                    loads.force[w] += r.force;
                    loads.normal[w] += r.force.dot(&inward).max(0.0);
                    loads.stiffness[w] += r.stiffness;
                    loads.contacts[w] += 1;
                }
            }
            loads
        },
    )
}
