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

use super::blocks::{for_blocks, Rows};
use super::pair_records::{BlockPairs, PairInputs, PairOut, PairRows};
use crate::effects::heat_ledger::cpu::HeatLanes;
use crate::model::Model;
use crate::physics::contact_law::{NormalLaw, PairState, TangentialLaw};
use crate::physics::Vec3;
use crate::plan::StepPlan;

pub use super::pair_records::Breaks;

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
/// when they hold the current ones, else from the rows. The pairs go through the law four at
/// a time (pair_batch.rs), in AVX2 where the processor has it: the same numbers either way.
pub(super) fn pair_pass<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool>(
    m: &Model,
    plan: &StepPlan,
    scratch: &mut PairScratch,
) -> Breaks {
    let from_records = scratch.records_current;
    scratch.records_current = true;
    let (inputs, rows) = (PairInputs::of(m, plan, ROT), PairRows::of(&m.contacts));
    let dashpots = Some(&mut scratch.dashpot[..]).filter(|_| T::DAMPED);
    let outs = (&mut scratch.out[..], dashpots);
    let avx2 = super::pair_batch::has_avx2();
    // A periodic cell's pairs measure through the nearest image, a 2D model's in the plane:
    // decided once a pass, so the pair loop of a plain 3D scene carries no test for either.
    // (A periodic 2D model takes the periodic instance, in three components.)
    let (periodic, planar) = (inputs.periodic, inputs.planar);
    for_blocks(0..m.particles.len(), Rows::Csr(&m.contacts.pair_start), (), outs, &|range, (), (out, dashpots)| {
        let block = BlockPairs { range, rows: &rows, from_records, out, dashpots };
        match (periodic, planar) {
            (true, _) => super::pair_batch::run::<N, T, DASHPOT, ROT, true, false>(&inputs, block, avx2),
            (false, true) => super::pair_batch::run::<N, T, DASHPOT, ROT, false, true>(&inputs, block, avx2),
            (false, false) => super::pair_batch::run::<N, T, DASHPOT, ROT, false, false>(&inputs, block, avx2),
        }
    })
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
                heat.book_row(li, &row.heat);
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

/// Sums one particle's row in row order and, given the row's pair states, mirrors the new
/// states into it. `pairs` are the row's pair ids, the pairs the particle owns start at
/// `own` and `radius` is its radius.
#[inline(always)]
pub(super) fn gather_row<T: TangentialLaw, const ROT: bool>(
    scratch: &PairScratch,
    pairs: &[u32],
    own: usize,
    radius: f64,
    state: Option<&mut [PairState]>,
) -> RowSum {
    let sc = &scratch.out[..];
    let mut sum = RowSum { force: Vec3::zeros(), torque: Vec3::zeros(), heat: [0.0; 3] };
    // One pair's record: its new state, and the tangential force (the spring, and the
    // dashpot of a damped law) and the whole force on the lower id.
    let record = |k: u32| {
        let out = &sc[k as usize];
        let tangential = if T::DAMPED { out.state.shear + scratch.dashpot[k as usize] } else { out.state.shear };
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
            *slot = mirrored(&sc[k as usize].state, e < own);
        }
    }
    sum
}
