//! What the pair pass reads and leaves: the particles' inputs, the rows it walks, one block's
//! pair records, and one pair through the scalar law. Both the pass (contact_forces.rs) and
//! its four-lane batches (pair_batch.rs) work on these.

use super::blocks::Reduce;
use crate::effects::periodic::setting::Image;
use crate::model::Model;
use crate::physics::contact_law::{
    contact, contact_opened, BreakKind, ContactGeometry, NormalLaw, PairState, TangentialLaw,
};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::state::contacts::Contacts;

/// Bonds that broke during the pass, in particle order: (i, j, kind) with i < j.
#[derive(Default)]
pub struct Breaks(pub Vec<(u32, u32, BreakKind)>);

impl Reduce for Breaks {
    fn combine(mut self, mut other: Self) -> Self {
        self.0.append(&mut other.0);
        self
    }
}

/// What the pair pass leaves for the gather pass about one pair, as seen from its lower id.
/// One record per pair, so the gather pass meets each pair in one place. The force on the
/// lower id is `state.shear − normal·normal_force`, the very expression the contact law
/// evaluates, so the gather pass recomputes it bit for bit from 8 bytes instead of 24
/// (this record is written and read back every step: its size is memory traffic).
#[derive(Clone, Copy, Default)]
pub(super) struct PairOut {
    /// New state.
    pub state: PairState,
    /// Unit normal from the lower id towards the higher (zero while apart).
    pub normal: Vec3,
    /// Normal force on the lower id, positive in compression (zero while apart).
    pub normal_force: f64,
    /// Heat of the whole pair this step: (dashpot, friction, breakage).
    pub heat: [f64; 3],
}

/// What the law reads of the particles.
pub(super) struct PairInputs<'a> {
    pub pos: &'a [Vec3],
    pub vel: &'a [Vec3],
    pub radius: &'a [f64],
    pub mass: &'a [f64],
    pub material: &'a [u32],
    /// The spins, when the plan rotates.
    pub ang_vel: Option<&'a [Vec3]>,
    pub plan: &'a StepPlan,
    pub dt: f64,
    /// The periodic cell's image arithmetic (a scene with periodic boundaries); the pass
    /// reads it only in its periodic instance.
    pub image: Image,
    pub periodic: bool,
    /// A 2D model (every centre, velocity and the spins' axis held in the x–z plane): the
    /// pass's lanes compute two components (`V4<true>`).
    pub planar: bool,
}

impl PairInputs<'_> {
    /// From i to j: through the nearest image in a periodic cell; and what that image's x
    /// velocity adds to v_i − v_j under Lees–Edwards shear (0 otherwise).
    #[inline(always)]
    pub fn separation<const PERIODIC: bool>(&self, i: usize, j: usize) -> (Vec3, f64) {
        let d = self.pos[j] - self.pos[i];
        if PERIODIC {
            self.image.nearest_sliding(d)
        } else {
            (d, 0.0)
        }
    }
}

/// The neighbour rows the pair pass walks.
pub(super) struct PairRows<'a> {
    pub row_start: &'a [u32],
    pub other: &'a [u32],
    pub state: &'a [PairState],
    pub pair_start: &'a [u32],
    /// Each row entry's pair id (read by debug checks only).
    pub pair: &'a [u32],
}

impl<'a> PairInputs<'a> {
    /// The model's lanes and step, with the spins when `rotation` (the plan rotates).
    pub fn of(m: &'a Model, plan: &'a StepPlan, rotation: bool) -> Self {
        let p = &m.particles;
        PairInputs {
            pos: &p.pos,
            vel: &p.vel,
            radius: &p.radius,
            mass: &p.mass,
            material: &p.material,
            ang_vel: p.rotation.as_ref().filter(|_| rotation).map(|r| &r.ang_vel[..]),
            plan,
            dt: m.clock.dt,
            image: m.effects.periodic.cell.map(|c| c.image()).unwrap_or_default(),
            periodic: m.effects.periodic.cell.is_some(),
            planar: m.settings.planar.is_some(),
        }
    }
}

impl<'a> PairRows<'a> {
    pub fn of(c: &'a Contacts) -> Self {
        PairRows { row_start: &c.row_start, other: &c.other, state: &c.state, pair_start: &c.pair_start, pair: &c.pair }
    }
}

/// One block of the pair pass: its particles, and the records of the pairs they own.
pub(super) struct BlockPairs<'a, 'r> {
    pub range: std::ops::Range<usize>,
    pub rows: &'r PairRows<'r>,
    /// The records hold the current pair states (else the rows do).
    pub from_records: bool,
    /// The block's records, from its first particle's first pair.
    pub out: &'a mut [PairOut],
    /// The block's tangential dashpot forces (a damped law only).
    pub dashpots: Option<&'a mut [Vec3]>,
}

impl BlockPairs<'_, '_> {
    /// The state pair `k` began this step with: its record's while that is current (the rows'
    /// copy is then not read: that read was ~10 % of a fused step's memory traffic), else its
    /// entry `e` in the lower id's row.
    #[inline(always)]
    pub fn state(&self, k: usize, e: usize) -> PairState {
        if self.from_records {
            self.out[k].state
        } else {
            self.rows.state[e]
        }
    }

    /// Stores the pair's results in its record `k` (block-local).
    #[inline(always)]
    pub fn store<T: TangentialLaw>(&mut self, k: usize, record: PairOut, tangential_dashpot: Vec3) {
        self.out[k] = record;
        if let Some(d) = self.dashpots.as_deref_mut().filter(|_| T::DAMPED) {
            d[k] = tangential_dashpot;
        }
    }
}

/// One pair `i` < `j` through the law, whatever its state, from the state `st` it began the
/// step with: its record, its tangential dashpot force, and the kind of break if its bond broke.
#[inline(always)]
pub(super) fn one_pair<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const PERIODIC: bool>(
    inp: &PairInputs,
    i: usize,
    j: usize,
    mut st: PairState,
) -> (PairOut, Vec3, Option<BreakKind>) {
    let (ri, vi) = (inp.radius[i], inp.vel[i]);
    let (d, slide) = inp.separation::<PERIODIC>(i, j);
    let rj = inp.radius[j];
    let touch = ri + rj;
    let dist2 = d.norm_squared();
    let (mut normal_force, mut nrm, mut heat) = (0.0, Vec3::zeros(), [0.0; 3]);
    let (mut td, mut broke) = (Vec3::zeros(), None);
    // The contact points' relative velocity along the normal `n`.
    let v_rel = |n: &Vec3| {
        let mut v_rel = vi - inp.vel[j];
        if PERIODIC {
            v_rel.x += slide;
        }
        if let Some(w) = inp.ang_vel {
            v_rel += w[i].cross(&(n * ri)) - w[j].cross(&(n * -rj));
        }
        v_rel
    };
    let pp = inp.plan.pair(inp.material[i], inp.material[j]);
    if !st.bonded && dist2 >= touch * touch {
        if st.shear != Vec3::zeros() || st.dashpot != 0.0 {
            // The contact has just opened.
            let nrm = d / dist2.sqrt();
            let (friction, damping) = contact_opened::<T>(pp, ri * rj / touch, &mut st, &nrm, v_rel(&nrm), inp.dt);
            heat = [damping, friction, 0.0];
        }
    } else {
        let dist = dist2.sqrt();
        nrm = d / dist;
        let (mi, mj) = (inp.mass[i], inp.mass[j]);
        let g = ContactGeometry {
            n: nrm,
            overlap: touch - dist,
            v_rel: v_rel(&nrm),
            r_star: ri * rj / touch,
            m_star: mi * mj / (mi + mj),
        };
        let r = contact::<N, T, DASHPOT>(&g, pp, &mut st, inp.dt);
        normal_force = r.normal_force;
        heat = [r.heat_damping, r.heat_friction, r.heat_breakage];
        td = r.tangential_dashpot;
        broke = r.broke;
    }
    (PairOut { state: st, normal: nrm, normal_force, heat }, td, broke)
}
