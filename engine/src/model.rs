//! The model: particles, contact rows, materials, groups, walls, settings and the clock.
//! Mutating calls validate their input and mark what a run must rebuild.

use crate::effects::parallel_bond::lanes::ParallelBonds;
use crate::effects::{EffectStates, NewElement};
use crate::error::{check_positive, Error, Result};
use crate::materials::base_name;
use crate::materials::Material;
use crate::physics::contact_law::{BreakKind, PairState};
pub use crate::physics::law_kinds::{NormalKind, TangentialKind};
use crate::physics::timestep::{critical_step, element_period, STANDARD_FRACTION};
use crate::physics::Vec3;
use crate::state::contacts::Contacts;
use crate::state::groups::Groups;
use crate::state::particles::{dof, Particles};
use crate::walls::{Wall, MAX_WALLS};
use serde::{Deserialize, Serialize};

/// Scene-wide choices.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// Gravitational acceleration (m/s²).
    pub gravity: Vec3,
    /// MatDEM's global viscous damping, as a ratio of each element's critical damping.
    pub damping: f64,
    /// Cundall's local damping coefficient α in [0, 1): −α·|F|·sign(v). It removes kinetic
    /// energy without slowing steady motion, which suits quasi-static balancing.
    pub local_damping: f64,
    pub normal: NormalKind,
    pub tangential: TangentialKind,
    /// Simulate particle rotation (torques from shear forces).
    pub rotation: bool,
    /// Neighbour skin as a fraction of the mean radius.
    pub skin_ratio: f64,
    /// Steps between stability checks.
    pub guard_every: u64,
    /// Largest overlap the guard accepts, as a fraction of the smaller radius.
    pub max_overlap_ratio: f64,
    /// What the guard does when dt is too long for the stiffest current contact.
    pub guard: crate::settings::guard::GuardMode,
    /// Keep the energy ledger: the heat each particle releases, by cause, and the work walls
    /// do (`Energies`' heat and wall work). Off, a plan allocates and books none of its lanes
    /// and the energies report no heat.
    pub heat_ledger: bool,
    /// Heat conduction and thermal expansion (the `conduction` stage; off by default). Saved
    /// after the model in a checkpoint (format 4), so that older checkpoints still read.
    #[serde(skip)]
    pub heat: crate::effects::conduction::settings::HeatSettings,
    /// The water table (the `buoyancy` stage; no water by default); saved as `heat` is.
    #[serde(skip)]
    pub water: crate::effects::buoyancy::settings::WaterTable,
    /// Rolling resistance (the `rolling_resistance` stage; off by default). Saved in a
    /// checkpoint's sections (format 7), so that older checkpoints still read.
    #[serde(skip)]
    pub rolling: Option<crate::effects::rolling_resistance::physics::RollingResistance>,
    /// Pore density flow (the `pore_flow` stage; off by default). Saved, with the network and
    /// its fluid, in a checkpoint's sections (format 7).
    #[serde(skip)]
    pub pores: crate::effects::pore_flow::PoreSettings,
    /// A 2D model's plate (`None`: 3D). Saved in a checkpoint's sections, so that older
    /// checkpoints still read.
    #[serde(skip)]
    pub planar: Option<crate::planar::setting::Planar>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            gravity: Vec3::zeros(),
            damping: 0.0,
            local_damping: 0.0,
            normal: NormalKind::Linear,
            tangential: TangentialKind::Linear,
            rotation: false,
            skin_ratio: 0.4,
            guard_every: 100,
            max_overlap_ratio: 0.5,
            guard: crate::settings::guard::GuardMode::Stop,
            heat_ledger: true,
            heat: crate::effects::conduction::settings::HeatSettings::default(),
            water: crate::effects::buoyancy::settings::WaterTable::default(),
            rolling: None,
            pores: crate::effects::pore_flow::PoreSettings::default(),
            planar: None,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    pub step: u64,
    pub time: f64,
    pub dt: f64,
}

/// A bond that broke: when, which pair (i < j) and how.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Breakage {
    pub step: u64,
    pub time: f64,
    pub i: u32,
    pub j: u32,
    pub kind: BreakKind,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Model {
    pub particles: Particles,
    pub contacts: Contacts,
    /// Shear state of particle–wall contacts: `wall_contacts[i * walls.len() + w]`.
    pub wall_contacts: Vec<PairState>,
    pub materials: Vec<Material>,
    pub groups: Groups,
    pub walls: Vec<Wall>,
    pub settings: Settings,
    pub clock: Clock,
    pub breakages: Vec<Breakage>,
    /// Bumped by every change that invalidates a step plan.
    pub revision: u64,
    /// The `parallel_bond` stage's bonds (empty unless the scene made them). Saved after the
    /// model in a checkpoint (format 3), so that a model of format 2 still reads.
    #[serde(skip)]
    pub parallel_bonds: ParallelBonds,
    /// The `rolling_resistance` stage's epsd rolling springs against the walls (N·m),
    /// `wall_rolling[i * walls.len() + w]` as `wall_contacts`; empty unless the plan has epsd.
    /// Saved in a checkpoint's sections (format 7) with the row springs.
    #[serde(skip)]
    pub wall_rolling: Vec<Vec3>,
    /// The `pore_flow` stage's network and fluid, when the scene enabled it
    /// ([`Model::enable_pore_flow`]). Saved in a checkpoint's sections (format 7).
    #[serde(skip)]
    pub pores: Option<Box<crate::effects::pore_flow::PoreFlow>>,
    /// The work done by changing gravity or the water table between runs, for the energy
    /// account (`body_potential`). Saved after a checkpoint's sections (format 8).
    #[serde(skip)]
    pub body_work: crate::state::body_work::BodyWork,
    /// The `clumps` stage's rigid bodies (empty unless the scene made clumps). Saved in a
    /// checkpoint's sections.
    #[serde(skip)]
    pub clumps: crate::effects::clumps::lanes::Clumps,
    /// The state of each effect that keeps one (its settings and lanes, `effects::EffectState`),
    /// grown and shrunk with the particles. Saved in a checkpoint's sections, by effect.
    #[serde(skip)]
    pub effects: EffectStates,
}

impl Default for Model {
    fn default() -> Self {
        Self::new()
    }
}

impl Model {
    pub fn new() -> Self {
        Model {
            particles: Particles::default(),
            contacts: Contacts { stale: true, ..Contacts::default() },
            wall_contacts: Vec::new(),
            materials: Vec::new(),
            groups: Groups::default(),
            walls: Vec::new(),
            settings: Settings::default(),
            clock: Clock { step: 0, time: 0.0, dt: 0.0 },
            breakages: Vec::new(),
            revision: 0,
            parallel_bonds: ParallelBonds::default(),
            wall_rolling: Vec::new(),
            pores: None,
            body_work: Default::default(),
            clumps: Default::default(),
            effects: EffectStates::default(),
        }
    }

    pub fn len(&self) -> usize {
        self.particles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// Heap bytes of the per-particle lanes: the particles' and the effects' states'.
    pub fn lane_bytes(&self) -> usize {
        self.particles.bytes() + self.effects.bytes()
    }

    pub(crate) fn touch(&mut self) {
        self.revision += 1;
    }

    /// Adds a material, or replaces the one with the same name; returns its index.
    pub fn add_material(&mut self, m: Material) -> Result<u32> {
        m.validate()?;
        self.touch();
        if let Some(k) = self.materials.iter().position(|x| x.name == m.name) {
            self.materials[k] = m;
            for i in 0..self.len() {
                if self.particles.material[i] as usize == k {
                    self.particles.mass[i] = self.sphere_mass(k, self.particles.radius[i]);
                }
            }
            return Ok(k as u32);
        }
        if self.materials.len() >= crate::materials::MAX_MATERIALS {
            return Err(Error::InvalidScene(format!(
                "material `{}`: a scene may have at most {} materials (the contact pass reads an M×M table of pair \
                 constants); reuse one, or bin per-element values into fewer classes",
                m.name,
                crate::materials::MAX_MATERIALS
            )));
        }
        self.materials.push(m);
        Ok(self.materials.len() as u32 - 1)
    }

    pub fn material_index(&self, name: &str) -> Result<u32> {
        self.materials.iter().position(|m| m.name == name).map(|k| k as u32).ok_or_else(|| {
            let known: Vec<&str> = self.materials.iter().map(|m| m.name.as_str()).collect();
            Error::unknown("material", name, &known)
        })
    }

    fn sphere_mass(&self, material: usize, r: f64) -> f64 {
        self.materials[material].density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r
    }

    /// Adds a sphere and returns its id.
    pub fn add_particle(&mut self, pos: Vec3, radius: f64, material: u32) -> Result<usize> {
        check_positive("radius", radius, false)?;
        if !pos.iter().all(|v| v.is_finite()) {
            return Err(Error::InvalidScene(format!("particle position {pos:?} is not finite")));
        }
        if material as usize >= self.materials.len() {
            return Err(Error::InvalidScene(format!(
                "material index {material} does not exist (the model has {})",
                self.materials.len()
            )));
        }
        self.check_in_plane(&pos)?;
        let mass = self.sphere_mass(material as usize, radius);
        let id = self.particles.push(pos, radius, mass, material);
        if self.settings.planar.is_some() {
            self.particles.fixed[id] |= crate::planar::setting::HELD;
        }
        self.parallel_bonds.fit(self.particles.len());
        if self.particles.thermal.temperature.len() == self.len() {
            self.particles.thermal.temperature[id] = self.settings.heat.reference;
            self.init_thermal(id);
        }
        let name = &self.materials[material as usize].name;
        let new = NewElement { id, radius, material: name, base_material: base_name(name) };
        self.effects.push(&new);
        let w = self.walls.len();
        self.wall_contacts.extend(std::iter::repeat_n(PairState::default(), w));
        if !self.wall_rolling.is_empty() {
            self.wall_rolling.extend(std::iter::repeat_n(Vec3::zeros(), w));
        }
        self.contacts.stale = true;
        self.touch();
        Ok(id)
    }

    pub fn check_ids(&self, ids: &[u32]) -> Result<()> {
        let n = self.len();
        match ids.iter().find(|&&i| i as usize >= n) {
            Some(&bad) => Err(Error::BadParticleId { id: bad as usize, count: n }),
            None => Ok(()),
        }
    }

    /// Assigns a material to particles (mass follows the density).
    pub fn set_material(&mut self, ids: &[u32], material: u32) -> Result<()> {
        self.check_ids(ids)?;
        if material as usize >= self.materials.len() {
            return Err(Error::InvalidScene(format!("material index {material} does not exist")));
        }
        for &i in ids {
            let i = i as usize;
            self.particles.material[i] = material;
            self.particles.mass[i] = self.sphere_mass(material as usize, self.particles.radius[i]);
        }
        self.touch();
        Ok(())
    }

    /// Sets particles' radii (`radii[k]` for particle `ids[k]`); mass follows the material's
    /// density, and with it the moment of inertia (2/5·m·r²). Every id and radius is checked
    /// before anything changes; the rows are rebuilt before the next force pass.
    pub fn set_radii(&mut self, ids: &[u32], radii: &[f64]) -> Result<()> {
        self.check_ids(ids)?;
        if ids.len() != radii.len() {
            return Err(Error::InvalidScene(format!("{} ids but {} radii", ids.len(), radii.len())));
        }
        if let Some((k, r)) = radii.iter().enumerate().find(|(_, r)| !(r.is_finite() && **r > 0.0)) {
            return Err(Error::InvalidScene(format!(
                "the radius of particle {} must be a finite number > 0 m, got {r}",
                ids[k]
            )));
        }
        for (&i, &r) in ids.iter().zip(radii) {
            let i = i as usize;
            self.particles.radius[i] = r;
            self.particles.mass[i] = self.sphere_mass(self.particles.material[i] as usize, r);
            // A radius set by hand is the element's radius at the reference temperature.
            if let Some(r0) = self.particles.thermal.radius0.get_mut(i) {
                *r0 = r;
            }
            self.effects.radius_set(i, r);
        }
        self.positions_changed();
        self.touch();
        Ok(())
    }

    /// Marks the neighbour rows stale after positions (or radii) were written directly, so
    /// the next force pass rebuilds them; contact and bond state of pairs that stay in reach
    /// is kept, as in a rebuild after drift.
    pub fn positions_changed(&mut self) {
        self.contacts.stale = true;
    }

    /// Blocks (or frees) translational degrees of freedom; blocked components keep their
    /// current velocity (zero unless a script sets one). A 2D model's held components
    /// ([`crate::planar::setting::HELD`]) stay held.
    pub fn fix(&mut self, ids: &[u32], dofs: u8, fixed: bool) -> Result<()> {
        self.check_ids(ids)?;
        let dofs = if fixed || self.settings.planar.is_none() { dofs } else { dofs & !crate::planar::setting::HELD };
        for &i in ids {
            let f = &mut self.particles.fixed[i as usize];
            // A killed element stays blocked in everything: freeing it would let it drift.
            if *f & dof::KILLED == 0 {
                *f = if fixed { *f | dofs } else { *f & !dofs };
            }
        }
        Ok(())
    }

    /// Applies an external force `force` (N) to each of `ids`, replacing the force it had, constant
    /// until changed (the `applied_loads` stage). A zero force removes it; when no element keeps a
    /// load the stage's lanes are released. The work the force does from here on is booked in the
    /// energy account (`Energies::applied_work`). Ids and the vector are checked first: a refused
    /// call changes nothing.
    pub fn apply_force(&mut self, ids: &[u32], force: Vec3) -> Result<()> {
        self.apply_loads(ids, Some(force), None)
    }

    /// Applies an external torque `torque` (N·m) to each of `ids`, as [`apply_force`](Self::apply_force)
    /// does a force. A torque needs the elements to turn: rotation is switched on.
    pub fn apply_torque(&mut self, ids: &[u32], torque: Vec3) -> Result<()> {
        self.apply_loads(ids, None, Some(torque))
    }

    fn apply_loads(&mut self, ids: &[u32], force: Option<Vec3>, torque: Option<Vec3>) -> Result<()> {
        self.check_ids(ids)?;
        let (what, v) = match (force, torque) {
            (Some(f), _) => ("applied force", f),
            (None, Some(t)) => ("applied torque", t),
            (None, None) => return Ok(()),
        };
        if !v.iter().all(|c| c.is_finite()) {
            return Err(Error::InvalidScene(format!(
                "{what} [{}, {}, {}] is not finite: give three finite numbers",
                v.x, v.y, v.z
            )));
        }
        let zero = v == Vec3::zeros();
        let n = self.len();
        if zero && !self.particles.applied.allocated(n) {
            // Nothing is loaded and nothing will be.
            return Ok(());
        }
        if torque.is_some() && !zero {
            self.settings.rotation = true;
            self.particles.enable_rotation();
        }
        self.particles.applied.fit(n);
        let p = &mut self.particles;
        for &i in ids {
            let i = i as usize;
            let angle = p.angle(i);
            p.applied.set(i, &p.pos[i], &angle, force, torque);
        }
        if p.applied.loaded() == 0 {
            let work = p.applied_work();
            p.applied.release(work);
        }
        self.touch();
        Ok(())
    }

    /// Removes every applied force and torque (their work to date stays in the account).
    pub fn clear_applied_loads(&mut self) {
        if self.particles.applied.allocated(self.len()) {
            let work = self.particles.applied_work();
            self.particles.applied.release(work);
            self.touch();
        }
    }

    pub fn add_wall(&mut self, wall: Wall) -> Result<usize> {
        if self.walls.len() >= MAX_WALLS {
            return Err(Error::InvalidScene(format!("a scene may have at most {MAX_WALLS} walls")));
        }
        if self.walls.iter().any(|w| w.name == wall.name) {
            return Err(Error::InvalidScene(format!("a wall named `{}` already exists", wall.name)));
        }
        // Re-stride the wall contact states.
        let w_old = self.walls.len();
        let mut states = vec![PairState::default(); self.len() * (w_old + 1)];
        for i in 0..self.len() {
            states[i * (w_old + 1)..i * (w_old + 1) + w_old]
                .copy_from_slice(&self.wall_contacts[i * w_old..(i + 1) * w_old]);
        }
        self.wall_contacts = states;
        if !self.wall_rolling.is_empty() {
            let mut springs = vec![Vec3::zeros(); self.len() * (w_old + 1)];
            for i in 0..self.len() {
                springs[i * (w_old + 1)..i * (w_old + 1) + w_old]
                    .copy_from_slice(&self.wall_rolling[i * w_old..(i + 1) * w_old]);
            }
            self.wall_rolling = springs;
        }
        self.walls.push(wall);
        self.touch();
        Ok(self.walls.len() - 1)
    }

    /// Removes the wall `name` (MatDEM's deleting a boundary: a triaxial sample's packing ring
    /// once the membrane holds it). Its contacts go with it; the work it did stays in the
    /// account. A platen the confining pressure spans is refused until the sample is unconfined.
    pub fn remove_wall(&mut self, name: &str) -> Result<()> {
        let k = self.wall_index(name)?;
        if let Some(c) = &self.effects.confining_pressure.confinement {
            if c.bottom == name || c.top == name {
                return Err(Error::InvalidScene(format!(
                    "wall `{name}` is a platen of the confining pressure: d.unconfine() first"
                )));
            }
        }
        let nw = self.walls.len();
        let keep = |j: usize| j % nw != k;
        let mut j = 0;
        self.wall_contacts.retain(|_| {
            j += 1;
            keep(j - 1)
        });
        if !self.wall_rolling.is_empty() {
            let mut j = 0;
            self.wall_rolling.retain(|_| {
                j += 1;
                keep(j - 1)
            });
        }
        self.walls.remove(k);
        // The wall masks' bits are wall indices, and those past `k` moved down one: the rows
        // are built again before the next step.
        self.contacts.stale = true;
        self.touch();
        Ok(())
    }

    pub fn wall_index(&self, name: &str) -> Result<usize> {
        self.walls.iter().position(|w| w.name == name).ok_or_else(|| {
            let known: Vec<&str> = self.walls.iter().map(|w| w.name.as_str()).collect();
            Error::unknown("wall", name, &known)
        })
    }

    pub fn wall_mut(&mut self, name: &str) -> Result<&mut Wall> {
        let k = self.wall_index(name)?;
        self.touch();
        Ok(&mut self.walls[k])
    }

    /// The stiffness an element meets in its stiffest likely contact (a rigid wall): the
    /// element spring 2·Kn, or for Hertz the tangent stiffness at an overlap of 5% of r; with
    /// parallel bonds, twice a bond's k̄n·A if that is stiffer (the standard step and the
    /// viscous damping then follow the bonds).
    pub fn element_stiffness(&self, i: usize) -> f64 {
        let m = &self.materials[self.particles.material[i] as usize];
        let contact = self.settings.normal.element_stiffness(m, self.particles.radius[i]);
        // A parallel bond to an element of the same size is a spring k̄n·A in parallel with the
        // contact; as the element's own spring, twice that (two in series give it back).
        match &self.parallel_bonds.params {
            Some(p) => {
                let r = self.particles.radius[i];
                let s = p.section(r, r);
                contact.max(2.0 * s.kn * s.area)
            }
            None => contact,
        }
    }

    /// The particle with the shortest element period and that period's critical step.
    pub fn critical_dt(&self) -> Option<(usize, f64)> {
        (0..self.len())
            .map(|i| (i, critical_step(self.particles.mass[i], self.element_stiffness(i))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// MatDEM's standard step: 1/50 of the smallest element period.
    pub fn standard_dt(&self) -> Result<f64> {
        let (i, dt) = (0..self.len())
            .map(|i| (i, element_period(self.particles.mass[i], self.element_stiffness(i)) * STANDARD_FRACTION))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or_else(|| {
                Error::InvalidScene("the model has no particles: add some before choosing a time step".into())
            })?;
        // A radius of 5e-321 m or 1e300 m gives a zero or infinite step: name its cause.
        if !(dt.is_finite() && dt > 0.0) {
            let p = &self.particles;
            return Err(Error::InvalidScene(format!(
                "the standard time step comes out as {dt} s, set by particle {i} (radius {:e} m, mass {:e} kg, \
                 stiffness {:e} N/m): its size or material is far outside physical values; give radii in metres \
                 and the material's Kn in N/m",
                p.radius[i],
                p.mass[i],
                self.element_stiffness(i)
            )));
        }
        Ok(dt)
    }

    pub fn set_dt(&mut self, dt: f64) -> Result<()> {
        check_positive("dt", dt, false)?;
        self.clock.dt = dt;
        Ok(())
    }

    pub fn set_standard_dt(&mut self) -> Result<f64> {
        let dt = self.standard_dt()?;
        self.clock.dt = dt;
        Ok(dt)
    }

    /// Mean radius (m).
    pub fn mean_radius(&self) -> f64 {
        let n = self.len().max(1) as f64;
        self.particles.radius.iter().sum::<f64>() / n
    }
}
