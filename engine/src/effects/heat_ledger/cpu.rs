//! The `heat_ledger` stage on the CPU: the energy ledger's lanes as the passes see them.
//!
//! Every cause of heat is a by-product of a core law (a dashpot's force, a sliding shear
//! spring, a breaking bond, damping, a moving wall's force), so the core passes book it where
//! they compute it, into the lanes the plan allocated ([`HeatLedger::fit`]). A lane the plan
//! does not have is `None` here: nothing is allocated, read or written for it, at the cost of
//! one well-predicted branch per particle and cause.

use crate::backend::cpu::blocks::Split;
use crate::state::particles::{HeatCauses, HeatLedger};

/// Allocates the ledger lanes of the plan's causes (before a step books into them).
pub fn fit(ledger: &mut HeatLedger, causes: &HeatCauses, n: usize) {
    ledger.fit(causes, n);
}

/// The ledger's lanes a pass books into, each present only when the plan has its cause.
#[derive(Default)]
pub(crate) struct HeatLanes<'a> {
    pub damping: Option<&'a mut [f64]>,
    pub contact_damping: Option<&'a mut [f64]>,
    pub friction: Option<&'a mut [f64]>,
    pub breakage: Option<&'a mut [f64]>,
    pub wall_work: Option<&'a mut [f64]>,
}

impl<'a> HeatLanes<'a> {
    /// The lanes of `causes` (which [`fit`] allocated).
    pub fn of(ledger: &'a mut HeatLedger, causes: &HeatCauses) -> Self {
        let on = |lane: &'a mut Vec<f64>, on: bool| on.then_some(&mut lane[..]);
        HeatLanes {
            damping: on(&mut ledger.damping, causes.damping),
            contact_damping: on(&mut ledger.contact_damping, causes.contact_damping),
            friction: on(&mut ledger.friction, causes.friction),
            breakage: on(&mut ledger.breakage, causes.breakage),
            wall_work: on(&mut ledger.wall_work, causes.wall_work),
        }
    }

    /// Books a particle's half of its row's pair heat, (dashpot, friction, breakage) summed
    /// over the row (`li`: its index in these lanes).
    #[inline(always)]
    pub fn book_row(&mut self, li: usize, heat: &[f64; 3]) {
        if let Some(l) = self.contact_damping.as_deref_mut() {
            l[li] += 0.5 * heat[0];
        }
        if let Some(l) = self.friction.as_deref_mut() {
            l[li] += 0.5 * heat[1];
        }
        if let Some(l) = self.breakage.as_deref_mut() {
            l[li] += 0.5 * heat[2];
        }
    }

    /// Particle `li`'s damping entry, if the plan books damping heat.
    #[inline(always)]
    pub fn damping_at(&mut self, li: usize) -> Option<&mut f64> {
        self.damping.as_deref_mut().map(|l| &mut l[li])
    }

    /// Particle `li`'s entries that wall contacts book into.
    #[inline(always)]
    pub fn walls_at(&mut self, li: usize) -> WallHeat<'_> {
        WallHeat {
            damping: self.contact_damping.as_deref_mut().map(|l| &mut l[li]),
            friction: self.friction.as_deref_mut().map(|l| &mut l[li]),
            work: self.wall_work.as_deref_mut().map(|l| &mut l[li]),
        }
    }
}

/// One particle's ledger entries a wall contact adds to.
pub(crate) struct WallHeat<'a> {
    pub damping: Option<&'a mut f64>,
    pub friction: Option<&'a mut f64>,
    pub work: Option<&'a mut f64>,
}

/// Adds `x` to a ledger entry the plan has.
#[inline(always)]
pub(crate) fn book(entry: &mut Option<&mut f64>, x: f64) {
    if let Some(e) = entry.as_deref_mut() {
        *e += x;
    }
}

impl Split for HeatLanes<'_> {
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (d, d2) = self.damping.split_at(mid);
        let (c, c2) = self.contact_damping.split_at(mid);
        let (f, f2) = self.friction.split_at(mid);
        let (b, b2) = self.breakage.split_at(mid);
        let (w, w2) = self.wall_work.split_at(mid);
        (
            HeatLanes { damping: d, contact_damping: c, friction: f, breakage: b, wall_work: w },
            HeatLanes { damping: d2, contact_damping: c2, friction: f2, breakage: b2, wall_work: w2 },
        )
    }
}
