//! The `contact_forces` stage: contact forces between particles, in two passes over particle
//! blocks, so that no two tasks write the same memory and sums never depend on the thread count:
//!
//! 1. *pairs*: each particle evaluates the pairs it owns (its higher-id neighbours, the
//!    tail of its row) once, and leaves the force, the new pair state, the normal and the
//!    heat in a per-pair scratch;
//! 2. *gather*: each particle walks its whole row in order, summing +F for the pairs it owns
//!    and −F for the others, and copies (mirrors) the new state into its row.
//!
//! The contact law is exactly odd in (n, v_rel, shear), so this gives the numbers that
//! evaluating every pair from both rows gave, bit for bit (up to the sign of a zero), at half
//! the cost of the contact law. The loops are monomorphised for the plan's laws.

use super::blocks::{for_blocks, Reduce, Rows};
use super::heat::HeatLanes;
use crate::model::Model;
use crate::physics::contact_law::{
    contact, contact_opened, BreakKind, ContactGeometry, NormalLaw, PairState, TangentialLaw,
};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::state::contacts::Contacts;
use std::ops::Range;

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
    state: PairState,
    /// Unit normal from the lower id towards the higher (zero while apart).
    normal: Vec3,
    /// Normal force on the lower id, positive in compression (zero while apart).
    normal_force: f64,
    /// Heat of the whole pair this step: (dashpot, friction, breakage).
    heat: [f64; 3],
}

/// Per-pair results passed from the pair pass to the gather pass, indexed by pair id
/// ([`Contacts::pair`](crate::state::contacts::Contacts::pair)). Kept between steps so a
/// step allocates nothing.
///
/// Within a run of steps the records are also where the pair states live: each pair's state
/// is in one record, once, but in the rows twice (at both ends). So a fused step reads the
/// states from the records and leaves the rows behind, and the rows are written once, when
/// something is about to read them ([`sync_rows`]): a fused step writes 32 bytes per
/// contact less and reads 16 (the standard scene's state traffic, ~280 bytes a particle).
#[derive(Default)]
pub struct PairScratch {
    out: Vec<PairOut>,
    /// The tangential dashpot's force on the lower id (a tangential law with a dashpot only;
    /// empty otherwise, so `PairOut` stays as small for every other law).
    dashpot: Vec<Vec3>,
    /// The records hold the pairs' current states: a pair pass has run on these rows and
    /// nothing has written the rows since. The next pair pass reads its states from them.
    pub(super) records_current: bool,
    /// The rows' copies of the pair states are older than the records'.
    pub(super) rows_behind: bool,
}

impl PairScratch {
    pub(super) fn fit<T: TangentialLaw>(&mut self, pairs: usize) {
        // Every entry is overwritten by the pair pass: only the length matters.
        if self.out.len() != pairs {
            self.out.resize(pairs, PairOut::default());
            self.records_current = false;
        }
        let dashpots = if T::DAMPED { pairs } else { 0 };
        if self.dashpot.len() != dashpots {
            self.dashpot.resize(dashpots, Vec3::zeros());
            self.dashpot.shrink_to_fit();
        }
    }

    /// Heap bytes held.
    pub fn bytes(&self) -> usize {
        self.out.capacity() * std::mem::size_of::<PairOut>() + self.dashpot.capacity() * std::mem::size_of::<Vec3>()
    }

    /// The records and (a damped tangential law only) the tangential dashpots' forces, by pair.
    pub(super) fn lanes<T: TangentialLaw>(&mut self) -> (&mut [PairOut], Option<&mut [Vec3]>) {
        (&mut self.out[..], Some(&mut self.dashpot[..]).filter(|_| T::DAMPED))
    }

    /// A pair pass begins: whether it reads the pair states from the records (else from the
    /// rows). After it they are in the records.
    pub(super) fn begin_pass(&mut self) -> bool {
        std::mem::replace(&mut self.records_current, true)
    }

    /// From now on the rows are the pair states' only source: the caller may write them or
    /// rebuild them (the rows must not be behind: [`sync_rows`] first).
    pub(super) fn forget_records(&mut self) {
        debug_assert!(!self.rows_behind, "pair states dropped before the rows were synced");
        self.records_current = false;
    }
}

/// Writes the pair states the records hold into both ends of each pair's rows, if the rows
/// are behind (fused steps leave them so): the rows then hold every state, as after a step
/// of separate passes. Bitwise the states the gather pass would have written.
pub fn sync_rows(m: &mut Model, scratch: &mut PairScratch) {
    if !scratch.rows_behind {
        return;
    }
    let c = &mut m.contacts;
    let (row_start, pair_start, pair) = (&c.row_start[..], &c.pair_start[..], &c.pair[..]);
    let sc = &scratch.out[..];
    for_blocks(
        0..row_start.len().saturating_sub(1),
        Rows::Csr(row_start),
        (),
        &mut c.state[..],
        &|range, (), state: &mut [PairState]| {
            let base = row_start[range.start] as usize;
            for i in range.clone() {
                let (start, end) = (row_start[i] as usize, row_start[i + 1] as usize);
                let own = end - (pair_start[i + 1] - pair_start[i]) as usize;
                for (e, slot) in (start..end).zip(&mut state[start - base..end - base]) {
                    *slot = mirrored(&sc[pair[e] as usize].state, e < own);
                }
            }
        },
    );
    scratch.rows_behind = false;
}

/// A pair's state as its row at one end holds it: the record's (the lower id's), or, seen
/// from the higher id, with the opposite shear (0 − s keeps +0).
#[inline(always)]
fn mirrored(state: &PairState, from_higher: bool) -> PairState {
    if from_higher {
        PairState { shear: Vec3::zeros() - state.shear, ..*state }
    } else {
        *state
    }
}

/// Overwrites `force` (and `torque`) with the contact forces of this step. The rows must
/// carry pair ids (as [`rebuild`](crate::neighbours::rebuild) leaves them).
pub fn compute_contact_forces(m: &mut Model, plan: &StepPlan, scratch: &mut PairScratch) -> Breaks {
    crate::with_laws!(plan, contact_loop[plan.dashpot, plan.rotation](m, plan, scratch))
}

fn contact_loop<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool>(
    m: &mut Model,
    plan: &StepPlan,
    scratch: &mut PairScratch,
) -> Breaks {
    let rotation = ROT && m.particles.rotation.is_some();
    debug_assert!(m.contacts.has_pair_ids(), "rows without pair ids: rebuild them first");
    scratch.fit::<T>(m.contacts.pair_count());
    let breaks = pair_pass::<N, T, DASHPOT, ROT>(m, plan, scratch);
    if rotation {
        gather_pass::<T, true>(m, plan, scratch);
    } else {
        gather_pass::<T, false>(m, plan, scratch);
    }
    scratch.rows_behind = false;
    breaks
}

/// Pass 1: every pair once, from its lower id. It reads the pair states from the records
/// when they hold the current ones, else from the rows.
pub(super) fn pair_pass<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool>(
    m: &Model,
    plan: &StepPlan,
    scratch: &mut PairScratch,
) -> Breaks {
    let cx = PairPass::start(m, plan, scratch);
    let p = &m.particles;
    let kin = Kinematics::of::<ROT>(p, 0);
    let pair_start = cx.pair_start;
    for_blocks(0..p.len(), Rows::Csr(pair_start), (), scratch.lanes::<T>(), &|range, (), (out, mut dashpots)| {
        let base = pair_start[range.start] as usize;
        let mut breaks = Breaks::default();
        for i in range.clone() {
            let tail = cx.owned(i);
            let k0 = cx.pair_start[i] as usize - base;
            let records = &mut out[k0..k0 + tail.len()];
            let dashpots = dashpots.as_deref_mut().map(|d| &mut d[k0..k0 + tail.len()]);
            cx.owned_pairs::<N, T, DASHPOT, ROT>(&kin, i, tail, records, dashpots, &mut breaks);
        }
        breaks
    })
}

/// What every pair of a pair pass reads, and where its owned pairs are.
pub(super) struct PairPass<'a> {
    plan: &'a StepPlan,
    dt: f64,
    radius: &'a [f64],
    mass: &'a [f64],
    material: &'a [u32],
    row_start: &'a [u32],
    pub(super) pair_start: &'a [u32],
    other: &'a [u32],
    /// The rows' copies of the pair states, read when the records' are not current.
    state: &'a [PairState],
    from_records: bool,
}

/// The particles' positions and velocities a pair pass reads: the lanes from particle `first`
/// on (a block-local pass holds only its own block's lanes).
pub(super) struct Kinematics<'a> {
    pub pos: &'a [Vec3],
    pub vel: &'a [Vec3],
    pub ang_vel: Option<&'a [Vec3]>,
    pub first: usize,
}

impl<'a> Kinematics<'a> {
    pub(super) fn of<const ROT: bool>(p: &'a crate::state::particles::Particles, first: usize) -> Self {
        let ang_vel = p.rotation.as_ref().filter(|_| ROT).map(|r| &r.ang_vel[first..]);
        Kinematics { pos: &p.pos[first..], vel: &p.vel[first..], ang_vel, first }
    }
}

impl<'a> PairPass<'a> {
    /// The pass's inputs; from here on the records hold the current pair states.
    pub(super) fn start(m: &'a Model, plan: &'a StepPlan, scratch: &mut PairScratch) -> Self {
        let p = &m.particles;
        Self::of(plan, m.clock.dt, (&p.radius, &p.mass, &p.material), &m.contacts, scratch.begin_pass())
    }

    /// The pass's inputs from the model's parts: the particles' (radius, mass, material), the
    /// rows, and whether the records hold the pair states ([`PairScratch::begin_pass`]).
    pub(super) fn of(
        plan: &'a StepPlan,
        dt: f64,
        (radius, mass, material): (&'a [f64], &'a [f64], &'a [u32]),
        c: &'a Contacts,
        from_records: bool,
    ) -> Self {
        PairPass {
            plan,
            dt,
            radius,
            mass,
            material,
            row_start: &c.row_start,
            pair_start: &c.pair_start,
            other: &c.other,
            state: &c.state,
            from_records,
        }
    }

    /// The pairs particle `i` owns, the tail of its row: the entries' range in the row lanes.
    #[inline(always)]
    pub(super) fn owned(&self, i: usize) -> Range<usize> {
        let end = self.row_start[i + 1] as usize;
        end - (self.pair_start[i + 1] - self.pair_start[i]) as usize..end
    }

    /// How many of the entries `tail` (row positions, as [`owned`](Self::owned) gives them)
    /// have their other end below `limit`: rows are sorted, so they come first.
    #[inline(always)]
    pub(super) fn below(&self, tail: &Range<usize>, limit: usize) -> usize {
        self.other[tail.clone()].partition_point(|&j| (j as usize) < limit)
    }

    /// Evaluates particle `i`'s pairs at the row entries `tail` (some of those it owns, in row
    /// order) into their `records` (and the tangential dashpots' forces, for a damped law).
    #[inline(always)]
    pub(super) fn owned_pairs<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool>(
        &self,
        kin: &Kinematics<'_>,
        i: usize,
        tail: Range<usize>,
        records: &mut [PairOut],
        mut dashpots: Option<&mut [Vec3]>,
        breaks: &mut Breaks,
    ) {
        let (plan, dt, radius, mass, material) = (self.plan, self.dt, self.radius, self.mass, self.material);
        let (pos, vel, ang_vel, o) = (kin.pos, kin.vel, kin.ang_vel, kin.first);
        let (xi, ri, vi, mi, mati) = (pos[i - o], radius[i], vel[i - o], mass[i], material[i]);
        let wi = ang_vel.map_or(Vec3::zeros(), |w| w[i - o]);
        // The row's tail and the scratch records are walked in step, as slices checked
        // once per particle rather than indexed (and bounds-checked) once per pair.
        let row_states = &self.state[tail.clone()];
        for (n, (&j, record)) in self.other[tail].iter().zip(records.iter_mut()).enumerate() {
            let j = j as usize;
            debug_assert!(j > i);
            // The rows' copy is not read when the record's is current: that read was
            // ~10 % of a fused step's memory traffic.
            let mut st = if self.from_records { record.state } else { row_states[n] };
            let d = pos[j - o] - xi;
            let rj = radius[j];
            let touch = ri + rj;
            let dist2 = d.norm_squared();
            let (mut normal_force, mut nrm, mut heat) = (0.0, Vec3::zeros(), [0.0; 3]);
            let mut td = Vec3::zeros();
            if !st.bonded && dist2 >= touch * touch {
                if st.shear != Vec3::zeros() || st.dashpot != 0.0 {
                    // The contact has just opened.
                    let nrm = d / dist2.sqrt();
                    let mut v_rel = vi - vel[j - o];
                    if let Some(w) = ang_vel {
                        v_rel += wi.cross(&(nrm * ri)) - w[j - o].cross(&(nrm * -rj));
                    }
                    let pp = plan.pair(mati, material[j]);
                    let (friction, damping) = contact_opened::<T>(pp, ri * rj / touch, &mut st, &nrm, v_rel, dt);
                    heat = [damping, friction, 0.0];
                }
            } else {
                let dist = dist2.sqrt();
                nrm = d / dist;
                let mut v_rel = vi - vel[j - o];
                if let Some(w) = ang_vel {
                    v_rel += wi.cross(&(nrm * ri)) - w[j - o].cross(&(nrm * -rj));
                }
                let mj = mass[j];
                let g = ContactGeometry {
                    n: nrm,
                    overlap: touch - dist,
                    v_rel,
                    r_star: ri * rj / touch,
                    m_star: mi * mj / (mi + mj),
                };
                let r = contact::<N, T, DASHPOT>(&g, plan.pair(mati, material[j]), &mut st, dt);
                normal_force = r.normal_force;
                heat = [r.heat_damping, r.heat_friction, r.heat_breakage];
                td = r.tangential_dashpot;
                if let Some(kind) = r.broke {
                    breaks.0.push((i as u32, j as u32, kind));
                }
            }
            *record = PairOut { state: st, normal: nrm, normal_force, heat };
            if let Some(d) = dashpots.as_deref_mut().filter(|_| T::DAMPED) {
                d[n] = td;
            }
        }
    }
}

/// Pass 2: each particle sums its row in row order and mirrors the new pair states.
fn gather_pass<T: TangentialLaw, const ROT: bool>(m: &mut Model, plan: &StepPlan, scratch: &PairScratch) {
    let Model { particles: p, contacts: c, .. } = m;
    let radius = &p.radius;
    let torque = match &mut p.rotation {
        Some(r) if ROT => Some(&mut r.torque[..]),
        _ => None,
    };
    let lanes = (&mut p.force[..], torque, HeatLanes::of(&mut p.heat, &plan.heat));
    let (row_start, pair_start, pair) = (&c.row_start[..], &c.pair_start[..], &c.pair[..]);
    for_blocks(
        0..radius.len(),
        Rows::Csr(row_start),
        lanes,
        &mut c.state[..],
        &|range, (force, mut torque, mut heat), state: &mut [PairState]| {
            let base = row_start[range.start] as usize;
            for i in range.clone() {
                let li = i - range.start;
                let (start, end) = (row_start[i] as usize, row_start[i + 1] as usize);
                let own = end - (pair_start[i + 1] - pair_start[i]) as usize;
                let row = gather_row::<T, ROT>(
                    scratch,
                    &pair[start..end],
                    own - start,
                    radius[i],
                    Some(&mut state[start - base..end - base]),
                );
                force[li] = row.force;
                if let Some(tq) = torque.as_deref_mut() {
                    tq[li] = row.torque;
                }
                heat.book_row(li, &row);
            }
        },
    )
}

/// One particle's row summed: the force and torque (rotation only) of its contacts and
/// the heat of its pairs, whole.
pub(super) struct RowSum {
    pub force: Vec3,
    pub torque: Vec3,
    /// (dashpot, friction, breakage).
    pub heat: [f64; 3],
}

/// Where a gather reads the pair records: the scratch itself, or a block-local pass's shared
/// view of it ([`SharedRecords`]).
pub(super) trait Records: Sync {
    /// Pair `k`'s record.
    fn out(&self, k: u32) -> &PairOut;
    /// Pair `k`'s tangential dashpot force (a damped tangential law only).
    fn dashpot(&self, k: u32) -> Vec3;
}

impl Records for PairScratch {
    #[inline(always)]
    fn out(&self, k: u32) -> &PairOut {
        &self.out[k as usize]
    }
    #[inline(always)]
    fn dashpot(&self, k: u32) -> Vec3 {
        self.dashpot[k as usize]
    }
}

/// The pair records as the tasks of a block-local pass share them (fused.rs): each task
/// writes the records of the pairs with both ends in its block and reads those with one end
/// in it. The pairs between blocks were written before the pass began and are only read
/// during it, and two blocks have no pair inside both, so no record is written by one task
/// while another reads it. Safe Rust cannot say this (a task's pairs are not one range of
/// the records), hence the raw pointers.
#[derive(Clone, Copy)]
pub(super) struct SharedRecords<'a> {
    out: *mut PairOut,
    dashpot: *mut Vec3,
    len: usize,
    damped: bool,
    _scratch: std::marker::PhantomData<&'a mut PairScratch>,
}

// SAFETY: the tasks touch disjoint records for writing, and records nobody writes for
// reading (see the type's doc); the pointers are valid for the borrow of the scratch.
unsafe impl Send for SharedRecords<'_> {}
// SAFETY: as for Send.
unsafe impl Sync for SharedRecords<'_> {}

impl<'a> SharedRecords<'a> {
    pub(super) fn new(scratch: &'a mut PairScratch) -> Self {
        SharedRecords {
            out: scratch.out.as_mut_ptr(),
            dashpot: scratch.dashpot.as_mut_ptr(),
            len: scratch.out.len(),
            damped: !scratch.dashpot.is_empty(),
            _scratch: std::marker::PhantomData,
        }
    }

    /// The records (and dashpot forces) of pairs `range`, to write.
    ///
    /// # Safety
    /// No other task may read or write these records while the slices live: they must be
    /// pairs with both ends in the caller's block.
    #[inline(always)]
    pub(super) unsafe fn owned_mut(&self, range: Range<usize>) -> (&mut [PairOut], Option<&mut [Vec3]>) {
        assert!(range.start <= range.end && range.end <= self.len);
        // SAFETY: in bounds (above); exclusive by the caller's contract.
        unsafe {
            let out = std::slice::from_raw_parts_mut(self.out.add(range.start), range.len());
            let dashpot =
                self.damped.then(|| std::slice::from_raw_parts_mut(self.dashpot.add(range.start), range.len()));
            (out, dashpot)
        }
    }
}

impl Records for SharedRecords<'_> {
    #[inline(always)]
    fn out(&self, k: u32) -> &PairOut {
        assert!((k as usize) < self.len);
        // SAFETY: in bounds; a record a task reads is not written meanwhile (the type's doc).
        unsafe { &*self.out.add(k as usize) }
    }
    #[inline(always)]
    fn dashpot(&self, k: u32) -> Vec3 {
        assert!(self.damped && (k as usize) < self.len);
        // SAFETY: as for `out`.
        unsafe { *self.dashpot.add(k as usize) }
    }
}

/// Sums one particle's row in row order and, given the row's pair states, mirrors the new
/// states into it. `pairs` are the row's pair ids, the pairs the particle owns start at
/// `own` and `radius` is its radius.
#[inline(always)]
pub(super) fn gather_row<T: TangentialLaw, const ROT: bool>(
    sc: &impl Records,
    pairs: &[u32],
    own: usize,
    radius: f64,
    state: Option<&mut [PairState]>,
) -> RowSum {
    let mut sum = RowSum { force: Vec3::zeros(), torque: Vec3::zeros(), heat: [0.0; 3] };
    // One pair's record: its new state, and the tangential force (the spring, and the
    // dashpot of a damped law) and the whole force on the lower id.
    let record = |k: u32| {
        let out = sc.out(k);
        let tangential = if T::DAMPED { out.state.shear + sc.dashpot(k) } else { out.state.shear };
        (out, tangential, tangential - out.normal * out.normal_force)
    };
    // Torque and heat are the same from both ends: (n·r_i) × s keeps its sign as n and s
    // both flip, and a pair's heat is the whole pair's.
    let add_both_ends = |sum: &mut RowSum, out: &PairOut, tangential: &Vec3| {
        if ROT {
            sum.torque += (out.normal * radius).cross(tangential);
        }
        let [d, fr, b] = out.heat;
        sum.heat[0] += d;
        sum.heat[1] += fr;
        sum.heat[2] += b;
    };
    // The row is the pairs of lower-id neighbours, then the particle's own: two loops in row
    // order (the same sums as one), so no entry asks which kind it is.
    let (lower, owned) = pairs.split_at(own);
    for &k in lower {
        let (out, tangential, force) = record(k);
        // Seen from the higher id: the opposite force.
        sum.force -= force;
        add_both_ends(&mut sum, out, &tangential);
    }
    for &k in owned {
        let (out, tangential, force) = record(k);
        sum.force += force;
        add_both_ends(&mut sum, out, &tangential);
    }
    if let Some(state) = state {
        for (e, (&k, slot)) in pairs.iter().zip(state).enumerate() {
            *slot = mirrored(&sc.out(k).state, e < own);
        }
    }
    sum
}
