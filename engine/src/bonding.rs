//! Making and breaking bonds between runs (MatDEM's `connect`, parallel bonds, joints): calls
//! on the model that edit its rows' pair states, rebuilding the rows first where a bond must
//! find its pairs.

use crate::effects::parallel_bond::physics::ParallelBondParams;
use crate::error::{check_positive, Error, Result};
use crate::model::Model;
use crate::physics::contact_law::PairState;
use crate::physics::Vec3;

impl Model {
    /// Bonds every pair among `ids` (all particles when `None`) whose gap is at most
    /// `tolerance` (m), like MatDEM's `connectGroup`. Returns the number of new bonds.
    pub fn connect(&mut self, ids: Option<&[u32]>, tolerance: f64) -> Result<usize> {
        check_positive("tolerance", tolerance, true)?;
        let member = self.membership(ids)?;
        self.connect_where(&member, &member, tolerance)
    }

    /// Bonds every pair with one end among `a` and the other among `b` whose gap is at most
    /// `tolerance` (m): a structure to a packing, or one block to another, without bonding
    /// either inside itself. Returns the number of new bonds.
    pub fn connect_between(&mut self, a: &[u32], b: &[u32], tolerance: f64) -> Result<usize> {
        check_positive("tolerance", tolerance, true)?;
        let (a, b) = (self.membership(Some(a))?, self.membership(Some(b))?);
        self.connect_where(&a, &b, tolerance)
    }

    fn connect_where(&mut self, a: &[bool], b: &[bool], tolerance: f64) -> Result<usize> {
        if self.contacts.skin <= 0.0 {
            // Not built yet: the usual skin, or a tiny bonding tolerance would become the skin
            // and the rows would be rebuilt every step.
            self.contacts.skin = self.settings.skin_ratio * self.mean_radius();
        }
        let skin_needed = tolerance;
        if self.contacts.skin < skin_needed || self.contacts.stale {
            self.contacts.skin = self.contacts.skin.max(skin_needed * 1.01);
            crate::neighbours::rebuild(self);
        }
        let image = self.effects.periodic.cell.map(|cell| cell.image());
        let p = &self.particles;
        let c = &mut self.contacts;
        let mut count = 0;
        for i in 0..p.len() {
            for e in c.row_start[i] as usize..c.row_start[i + 1] as usize {
                let j = c.other[e] as usize;
                if !((a[i] && b[j]) || (a[j] && b[i])) {
                    continue;
                }
                let d = p.pos[j] - p.pos[i];
                let gap = image.map_or(d, |im| im.nearest(d)).norm() - p.radius[i] - p.radius[j];
                if gap <= tolerance && !c.state[e].bonded {
                    c.state[e].bonded = true;
                    c.state[e].weakened = 0;
                    c.state[e].shear = Vec3::zeros();
                    if i < j {
                        count += 1;
                    }
                }
            }
        }
        self.touch();
        Ok(count)
    }

    /// Turns every MatDEM bond into a parallel bond with `params` (Potyondy & Cundall's model,
    /// effects/parallel_bond/physics.rs): the pair keeps a plain linear contact (compression and
    /// friction, no tension) and gains a bond of radius λ̄·min(Ri, Rj) in parallel with it,
    /// unloaded at the current positions. Rotation is simulated from then on. Returns the
    /// number of bonds made; refuses a model with none (connect it first) and bad parameters.
    pub fn bond_parallel(&mut self, params: ParallelBondParams) -> Result<usize> {
        params.validate().map_err(Error::InvalidScene)?;
        let c = &mut self.contacts;
        let mut pairs = Vec::new();
        for i in 0..c.row_start.len().saturating_sub(1) {
            for e in c.row_start[i] as usize..c.row_start[i + 1] as usize {
                if c.state[e].bonded {
                    if (i as u32) < c.other[e] {
                        pairs.push((i as u32, c.other[e]));
                    }
                    c.state[e].bonded = false;
                    // The parallel bond takes over: no joint share is left on the pair.
                    c.state[e].weakened = 0;
                    c.state[e].shear = Vec3::zeros();
                }
            }
        }
        if pairs.is_empty() {
            return Err(Error::InvalidScene(
                "bond_parallel found no bonded pairs: connect the particles first (d.connect), then make the \
                 bonds parallel"
                    .into(),
            ));
        }
        self.parallel_bonds.make(params, &pairs, self.len());
        self.settings.rotation = true;
        self.particles.enable_rotation();
        self.contacts.stale = true;
        self.touch();
        Ok(pairs.len())
    }

    /// Breaks every bond that has at least one end among `ids` (all when `None`).
    pub fn break_bonds(&mut self, ids: Option<&[u32]>) -> Result<usize> {
        let member = self.membership(ids)?;
        let count = self.break_bonds_touching(&member);
        self.touch();
        Ok(count)
    }

    /// Breaks every bond with an end flagged in `member` (a script's cut or a kill, not a
    /// breakage the loads made: none is recorded). Returns how many broke.
    pub(crate) fn break_bonds_touching(&mut self, member: &[bool]) -> usize {
        let c = &mut self.contacts;
        let mut count = 0;
        for i in 0..c.row_start.len().saturating_sub(1) {
            for e in c.row(i) {
                let j = c.other[e] as usize;
                if (member[i] || member[j]) && c.state[e].bonded {
                    c.state[e].bonded = false;
                    c.state[e].weakened = 0;
                    c.state[e].shear = Vec3::zeros();
                    if i < j {
                        count += 1;
                    }
                }
            }
        }
        count
    }

    /// Sets every bond for which `selected(i, j)` holds (asked once per pair, i < j) to
    /// `share` of its material pair's strength (breaking force and Fs0): MatDEM's joints,
    /// bonds across a surface weakened. `share` 0 breaks them (no breakage is recorded: the
    /// script cut them); 1 makes them whole again. Not cumulative: a second call sets, it
    /// does not multiply. Returns the number of bonds set.
    pub fn set_bond_strength(&mut self, selected: impl Fn(usize, usize) -> bool, share: f64) -> Result<usize> {
        if !(0.0..=1.0).contains(&share) {
            return Err(Error::param("strength share", share, "must be between 0 (break) and 1 (whole)"));
        }
        let weakened = if share > 0.0 { PairState::weakened_for(share) } else { 0 };
        let c = &mut self.contacts;
        let mut count = 0;
        for i in 0..c.row_start.len().saturating_sub(1) {
            for e in c.row(i) {
                let j = c.other[e] as usize;
                if !c.state[e].bonded || !selected(i.min(j), i.max(j)) {
                    continue;
                }
                if share > 0.0 {
                    c.state[e].weakened = weakened;
                } else {
                    c.state[e] = PairState { dashpot: c.state[e].dashpot, ..PairState::default() };
                }
                if i < j {
                    count += 1;
                }
            }
        }
        self.touch();
        Ok(count)
    }

    /// The share of its strength the bond between `i` and `j` has, or `None` when they are
    /// not bonded.
    pub fn bond_strength(&self, i: usize, j: usize) -> Option<f64> {
        let e = self.contacts.find(i, j as u32)?;
        let st = &self.contacts.state[e];
        st.bonded.then(|| st.strength())
    }

    /// One flag per particle: in `ids`, or every particle when `None`.
    fn membership(&self, ids: Option<&[u32]>) -> Result<Vec<bool>> {
        let mut member = vec![ids.is_none(); self.len()];
        if let Some(ids) = ids {
            self.check_ids(ids)?;
            for &i in ids {
                member[i as usize] = true;
            }
        }
        Ok(member)
    }

    /// Bonded pairs (each once).
    pub fn bond_count(&self) -> usize {
        self.contacts.state.iter().filter(|s| s.bonded).count() / 2
    }
}
