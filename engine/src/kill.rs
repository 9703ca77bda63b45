//! Taking elements out of a scene. Killing during a run (MatDEM's `killElement`): an element
//! leaves the mechanics but keeps its id, so the ids, groups and records a script holds stay
//! valid. Removing ([`Model::remove_particles`], at the end of this file) deletes and renumbers:
//! the tool for building a model between runs.
//!
//! A killed element carries the [`dof::KILLED`] bit in its fixity lane, the lane both backends
//! already read, so the step needs no new lane and no new flag: every degree of freedom is
//! blocked at zero velocity (no motion, gravity moves nothing), the neighbour rows leave it out
//! (no contact ever forms with it: `neighbours::rebuild` on the CPU, shaders/rows.wgsl on the
//! GPU), and the walls skip it (the wall mask on the CPU, one test in shaders/wall_forces.wgsl).
//! Its bonds are broken when it is killed — not booked as breakages (`Model::breakages` lists
//! what the loads broke; a script's cut is not one), as `d.break_bonds` does — and so are its
//! parallel bonds.
//!
//! The energy account stays continuous: the kinetic energy the killed elements had and the
//! elastic energy of their contacts and bonds leave the model, and are booked as breakage heat
//! on the killed elements' ledger (spread evenly over them), so mechanical + heat − wall work
//! is the same just after a kill as just before. Their gravitational energy stays in the
//! account: it is constant, for they never move again. Statistics (contacts, coordination,
//! porosity, unbalanced force) and pictures leave them out.

use crate::effects::parallel_bond::physics::{status, BondState};
use crate::error::Result;
use crate::model::Model;
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::state::contacts::Contacts;
use crate::state::particles::dof;
use crate::status::{kinetic_energy, potential_energies};

/// What a kill did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct KillReport {
    /// Elements newly killed (ids already killed are skipped).
    pub killed: usize,
    /// Bonds (and parallel bonds) broken with them, each counted once.
    pub bonds_broken: usize,
    /// Mechanical energy that left with them, booked as breakage heat (J).
    pub energy: f64,
}

impl Model {
    /// Whether element `i` has been killed.
    #[inline]
    pub fn is_killed(&self, i: usize) -> bool {
        self.particles.fixed[i] & dof::KILLED != 0
    }

    /// The number of killed elements.
    pub fn killed_count(&self) -> usize {
        self.particles.fixed.iter().filter(|f| **f & dof::KILLED != 0).count()
    }

    /// Kills elements `ids` (MatDEM `killElement`): see the module's docs. Every id is checked
    /// before anything changes.
    pub fn kill(&mut self, ids: &[u32]) -> Result<KillReport> {
        self.check_ids(ids)?;
        let mut doomed: Vec<usize> = ids.iter().map(|&i| i as usize).filter(|&i| !self.is_killed(i)).collect();
        doomed.sort_unstable();
        doomed.dedup();
        let mut report = KillReport { killed: doomed.len(), ..KillReport::default() };
        if doomed.is_empty() {
            return Ok(report);
        }
        // A change of the body forces' fields not yet booked, booked with the doomed still in.
        self.book_body_work();
        // The account before: rows must be current for the elastic energy to be the step's.
        if self.contacts.stale || self.contacts.row_start.len() != self.len() + 1 {
            crate::neighbours::rebuild(self);
        }
        let before = self.mechanical_energy();
        let mut member = vec![false; self.len()];
        for &i in &doomed {
            member[i] = true;
        }
        self.detach_from_clumps(&member, None);
        report.bonds_broken = self.break_bonds_touching(&member);
        let pb = &mut self.parallel_bonds;
        for i in 0..pb.row_start.len().saturating_sub(1) {
            for e in pb.row(i) {
                let j = pb.other[e] as usize;
                if (member[i] || member[j]) && pb.state[e].intact() {
                    pb.state[e] = BondState { status: status::BROKEN, ..BondState::default() };
                    if i < j {
                        report.bonds_broken += 1;
                    }
                }
            }
        }
        let nw = self.walls.len();
        let p = &mut self.particles;
        for &i in &doomed {
            p.fixed[i] = dof::ALL | dof::ROTATION | dof::KILLED;
            p.vel[i] = Vec3::zeros();
            p.force[i] = Vec3::zeros();
            if let Some(rot) = &mut p.rotation {
                rot.ang_vel[i] = Vec3::zeros();
                rot.torque[i] = Vec3::zeros();
            }
            for st in &mut self.wall_contacts[i * nw..(i + 1) * nw] {
                *st = Default::default();
            }
            if !self.wall_rolling.is_empty() {
                self.wall_rolling[i * nw..(i + 1) * nw].fill(Vec3::zeros());
            }
        }
        // The rows without them: every pair of a killed element goes, the rest keep their state.
        crate::neighbours::rebuild(self);
        report.energy = before - self.mechanical_energy();
        if self.settings.heat_ledger && report.energy != 0.0 {
            let n = self.len();
            let lane = &mut self.particles.heat.breakage;
            if lane.len() != n {
                lane.resize(n, 0.0);
            }
            let share = report.energy / doomed.len() as f64;
            for &i in &doomed {
                lane[i] += share;
            }
        }
        self.touch();
        Ok(report)
    }

    /// Kinetic and potential energy at the current state (J), for the kill's account.
    fn mechanical_energy(&self) -> f64 {
        let plan = StepPlan::build(self);
        let mut e = potential_energies(self, &plan);
        e.kinetic = kinetic_energy(self);
        e.mechanical()
    }
}

impl Model {
    /// Removes particles (ids refer to the current numbering); groups are renumbered. Every
    /// pair between two survivors keeps its state (bond, shear spring, dashpot), bonded pairs
    /// whatever their distance; the pairs of a removed particle go with it.
    pub fn remove_particles(&mut self, ids: &[u32]) -> Result<()> {
        self.check_ids(ids)?;
        let mut keep = vec![true; self.len()];
        for &i in ids {
            keep[i as usize] = false;
        }
        let w = self.walls.len();
        let mut idx = 0usize;
        self.wall_contacts.retain(|_| {
            let r = keep[idx / w.max(1)];
            idx += 1;
            r
        });
        if !self.wall_rolling.is_empty() {
            let mut idx = 0usize;
            self.wall_rolling.retain(|_| {
                let r = keep[idx / w.max(1)];
                idx += 1;
                r
            });
        }
        let map = self.particles.retain(&keep);
        self.effects.retain(&keep);
        self.groups.remap(&map);
        self.parallel_bonds.retain(&map);
        // Rows refer to old ids: renumber the survivors' rows (the map keeps the order, so
        // rows stay sorted), then rebuild from them, which carries each pair's state over and
        // keeps bonded pairs however far apart. Rows built before particles were added cover
        // only the first ones; the rest start empty.
        let old = std::mem::take(&mut self.contacts);
        let built = old.row_start.len().saturating_sub(1);
        let mut kept = Contacts { stale: true, skin: old.skin, row_start: vec![0], ..Contacts::default() };
        for (i, _) in keep.iter().enumerate().filter(|(_, k)| **k) {
            if i < built {
                for e in old.row(i) {
                    if let Some(b) = map[old.other[e] as usize] {
                        kept.other.push(b);
                        kept.state.push(old.state[e]);
                        if let Some(s) = old.rolling.get(e) {
                            kept.rolling.push(*s);
                        }
                    }
                }
            }
            kept.row_start.push(kept.other.len() as u32);
        }
        self.contacts = kept;
        crate::neighbours::rebuild(self);
        let leaving: Vec<bool> = keep.iter().map(|k| !k).collect();
        self.detach_from_clumps(&leaving, Some(&map));
        self.touch();
        Ok(())
    }
}
