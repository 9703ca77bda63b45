//! The CPU reference backend (f64, rayon). One step is a sequence of named stages; each
//! has a file of its own and, on the GPU, a kernel of the same name. The neighbour rows it
//! steps on are the engine's ([`crate::neighbours`]); the run loop around its chunks is the
//! simulation's ([`crate::simulation`]).

pub mod blocks;
pub mod contact_forces;
pub mod fused;
pub mod integrate;
mod lanes;
mod pair_batch;
mod pair_records;
mod prefetch;
pub mod stage;
pub mod wall_forces;

use crate::effects;
use crate::effects::heat_ledger::cpu as heat_ledger;

use super::{Backend, Sampling};
use crate::error::Result;
use crate::guard::{check_state, too_stiff, StiffContact};
use crate::model::{Breakage, Model};
use crate::neighbours;
use crate::plan::{Role, Stage, StepPlan};
use crate::status::{potential_energies, Energies, EnergySample};
use contact_forces::{compute_contact_forces, sync_rows, Breaks, PairScratch};
use integrate::{integrate, Observed};
use stage::{CpuStage, StageInput};
use wall_forces::compute_wall_forces;

/// The rows of [`CPU_STAGES`] from the effects' list (`effects::with_cpu_passes!`).
macro_rules! cpu_stages {
    ($($stage:ident $name:ident,)*) => {
        /// Every optional stage's pass (`stage`), each in its effect's folder
        /// (`effects/<name>/cpu.rs`), in step order. The heat ledger has none: it is booked
        /// inside the passes that dissipate.
        const CPU_STAGES: &[(Stage, stage::Build)] = &[$((Stage::$stage, effects::$name::cpu::stage),)*];
    };
}
crate::with_cpu_passes!(cpu_stages);

/// Per-run derived data: the plan and each particle's viscous damping coefficient.
pub struct CpuBackend {
    pub plan: StepPlan,
    /// c_i = 2·ζ·√(m_i·k_i); empty when viscous damping is off.
    damping_c: Vec<f64>,
    /// Per-pair results passed between the two contact passes.
    pairs: PairScratch,
    /// The plan's optional stages (of `CPU_STAGES`), in step order.
    stages: Vec<(Stage, Box<dyn CpuStage>)>,
    /// A stage's error (pore flow's guard), returned at the end of the step that raised it.
    stage_error: Option<crate::error::Error>,
}

impl CpuBackend {
    /// The threads the CPU backend's passes run on: rayon's pool, which `RAYON_NUM_THREADS`
    /// sets (not the machine's cores: a sweep's point or a Slurm task may be given fewer).
    pub fn threads() -> usize {
        rayon::current_num_threads()
    }

    /// The backend for the model's plan as it is now.
    pub fn prepare(m: &Model) -> Self {
        let plan = StepPlan::build(m);
        let damping_c = plan.damping_coefficients(m);
        Self::with_plan(plan, damping_c)
    }

    /// The backend for `plan`, with the particles' viscous damping coefficients
    /// ([`StepPlan::damping_coefficients`]).
    pub fn with_plan(plan: StepPlan, damping_c: Vec<f64>) -> Self {
        let stages = CPU_STAGES
            .iter()
            .filter(|(stage, _)| plan.has(*stage))
            .filter_map(|(stage, build)| Some((*stage, build(&plan)?)))
            .collect();
        CpuBackend { plan, damping_c, pairs: PairScratch::default(), stages, stage_error: None }
    }

    /// Heap bytes of the backend's own per-particle and per-pair buffers.
    pub fn scratch_bytes(&self) -> usize {
        self.damping_c.capacity() * std::mem::size_of::<f64>()
            + self.pairs.bytes()
            + self.stages.iter().map(|(_, s)| s.scratch_bytes()).sum::<usize>()
    }

    /// Advances the model by one step as separate passes, one per named stage (what an
    /// observed step runs, without its energy sums), adding each stage's wall-clock time to
    /// `times`: what `matdem-rs bench --profile` reports. The heat ledger is booked inside the
    /// passes that dissipate, so its time is theirs.
    pub fn step_profiled(&mut self, m: &mut Model, times: &mut StageTimes) {
        use std::time::Instant;
        self.pairs.forget_records();
        let dt = m.clock.dt;
        if self.plan.rotation && m.particles.rotation.is_none() {
            m.particles.enable_rotation();
        }
        let n = m.particles.len();
        heat_ledger::fit(&mut m.particles.heat, &self.plan.heat, n);
        let t = Instant::now();
        for w in &mut m.walls {
            w.advance(dt);
        }
        times.add(Stage::Walls, t.elapsed());
        let t = Instant::now();
        if neighbours::is_stale(&m.contacts, &m.particles.pos, m.effects.periodic.cell.as_ref()) {
            neighbours::rebuild(m);
        } else if neighbours::walls_stale(&m.contacts, &m.walls, m.particles.len()) {
            neighbours::rebuild_wall_mask(m);
        }
        times.add(Stage::Neighbours, t.elapsed());
        let t = Instant::now();
        let breaks = compute_contact_forces(m, &self.plan, &mut self.pairs);
        record_breaks(m, breaks);
        times.add(Stage::ContactForces, t.elapsed());
        let t = Instant::now();
        compute_wall_forces(m, &self.plan);
        times.add(Stage::WallForces, t.elapsed());
        for stage in self.plan.runs(Role::Force) {
            let t = Instant::now();
            self.run_stage(m, stage);
            times.add(stage, t.elapsed());
        }
        let t = Instant::now();
        integrate(m, &self.plan, &self.damping_c);
        times.add(Stage::Integrate, t.elapsed());
        for stage in self.plan.runs(Role::Body).chain(self.plan.runs(Role::Field)) {
            let t = Instant::now();
            self.run_stage(m, stage);
            times.add(stage, t.elapsed());
        }
        m.clock.step += 1;
        m.clock.time += dt;
    }

    /// Advances the model by one step. Returns the energies at the start of the step's
    /// integer time when `observe`. The model may have been changed since the last step, and
    /// its rows hold every pair state after this one.
    pub fn step(&mut self, m: &mut Model, observe: bool) -> Option<Energies> {
        self.pairs.forget_records();
        let e = self.advance(m, observe);
        sync_rows(m, &mut self.pairs);
        e
    }

    /// One step of a run of steps, in which nothing but this backend touches the model: the
    /// pair states may stay in the pair records (`sync_rows` after the last).
    ///
    /// Order follows the physics: walls move first so contacts see this step's walls;
    /// forces are complete before integration.
    fn advance(&mut self, m: &mut Model, observe: bool) -> Option<Energies> {
        let dt = m.clock.dt;
        if self.plan.rotation && m.particles.rotation.is_none() {
            // `settings.rotation` was switched on without the angular lanes: allocate them,
            // or the contact and integration loops would silently skip rotation.
            m.particles.enable_rotation();
        }
        // The optional stages' lanes, allocated for the plan (a no-op once they are).
        let n = m.particles.len();
        heat_ledger::fit(&mut m.particles.heat, &self.plan.heat, n);
        for w in &mut m.walls {
            w.advance(dt);
        }
        if neighbours::is_stale(&m.contacts, &m.particles.pos, m.effects.periodic.cell.as_ref()) {
            // The rebuild carries each pair's state over from the rows.
            sync_rows(m, &mut self.pairs);
            self.pairs.forget_records();
            neighbours::rebuild(m);
        } else if neighbours::walls_stale(&m.contacts, &m.walls, m.particles.len()) {
            neighbours::rebuild_wall_mask(m);
        }
        // A force stage (parallel bonds, rolling resistance, pore flow, applied loads, buoyancy) adds its loads
        // between the core's forces and the move, so a plan with one runs the core's passes
        // apart instead of fused.
        if !observe && !self.plan.has_force_stage() {
            // Nothing is read between the forces and the move: finish each particle in one pass.
            let breaks = fused::forces_and_motion(m, &self.plan, &mut self.pairs, &self.damping_c);
            record_breaks(m, breaks);
            self.body_stages(m);
            self.field_stages(m);
            m.clock.step += 1;
            m.clock.time += dt;
            return None;
        }
        let breaks = compute_contact_forces(m, &self.plan, &mut self.pairs);
        let work_before: f64 = m.particles.heat.wall_work.iter().sum();
        compute_wall_forces(m, &self.plan);
        record_breaks(m, breaks);
        // The buoyancy is the last force stage (its drag reads the others' sum); the energies
        // book its drag's heat.
        let mut drag_heat = 0.0;
        for stage in self.plan.runs(Role::Force) {
            drag_heat += self.run_stage(m, stage).damping_heat;
        }
        if !observe {
            let _ = integrate(m, &self.plan, &self.damping_c);
            self.body_stages(m);
            self.field_stages(m);
            m.clock.step += 1;
            m.clock.time += dt;
            return None;
        }
        let mut e = potential_energies(m, &self.plan);
        // This step's wall work, F·Δp over the wall's move to its position now, was booked
        // with the force at the end of the move; count half of it (the trapezoid rule), or
        // while a platen loads the sample the account runs ahead by F·v·dt/2.
        e.wall_work -= 0.5 * (e.wall_work - work_before);
        let mut obs = integrate(m, &self.plan, &self.damping_c);
        for stage in self.plan.runs(Role::Body) {
            let o = self.run_stage(m, stage);
            obs.kinetic += o.kinetic;
            obs.damping_heat += o.damping_heat;
        }
        e.kinetic = obs.kinetic;
        // The kinetic energy is that of the integer time, half way through this step's
        // damping: book half of it, or the account runs half a step behind (an offset of
        // ζ·ω·dt of the kinetic energy, frozen in when the motion starts or stops).
        if self.plan.heat.damping {
            // The drag's heat (buoyancy, before the sample) likewise: half of this step's.
            e.heat_damping += 0.5 * (obs.damping_heat - drag_heat);
        }
        self.field_stages(m);
        m.clock.step += 1;
        m.clock.time += dt;
        Some(e)
    }
}

impl CpuBackend {
    /// One optional stage of the plan, at its role's place in the step: records the bonds it
    /// broke and keeps its error for the end of the step; returns what it adds to an observed
    /// step (a body stage's kinetic energy and damping heat, a force stage's drag heat).
    fn run_stage(&mut self, m: &mut Model, stage: Stage) -> Observed {
        let input = StageInput { plan: &self.plan, damping_c: &self.damping_c };
        let Some((_, pass)) = self.stages.iter_mut().find(|(s, _)| *s == stage) else {
            unreachable!("{stage} is not an optional stage of this plan (CPU_STAGES)")
        };
        match pass.run(m, &input) {
            Ok(booked) => {
                record_breaks(m, booked.breaks);
                booked.observed
            }
            Err(e) => {
                self.stage_error.get_or_insert(e);
                Observed::default()
            }
        }
    }

    /// The plan's body stages after the move, in step order.
    fn body_stages(&mut self, m: &mut Model) {
        for stage in self.plan.runs(Role::Body) {
            let _ = self.run_stage(m, stage);
        }
    }

    /// The plan's field stages after integration, in step order.
    fn field_stages(&mut self, m: &mut Model) {
        let stages = self.plan.runs(Role::Field);
        if stages.clone().next().is_none() {
            return;
        }
        // Their conductances read the bonds in the rows, and moisture writes the bonds'
        // strength shares there: the rows are the pair states' source again.
        sync_rows(m, &mut self.pairs);
        self.pairs.forget_records();
        for stage in stages {
            let _ = self.run_stage(m, stage);
        }
    }
}

impl Backend for CpuBackend {
    fn run_chunk(
        &mut self,
        m: &mut Model,
        steps: u64,
        sampling: Sampling,
        sample: &mut dyn FnMut(EnergySample),
    ) -> Result<()> {
        let mut samples = Vec::new();
        // Step the chunk on a pool thread: the stages' parallel loops then join within the
        // pool instead of waking it from outside several times per step.
        // The model may have changed between chunks: the first step reads the rows.
        self.pairs.forget_records();
        rayon::scope(|_| {
            for k in 0..steps {
                let (step, time) = (m.clock.step, m.clock.time);
                if let Some(energies) = self.advance(m, sampling.at(k)) {
                    samples.push(EnergySample { step, time, energies });
                }
                if self.stage_error.is_some() {
                    break;
                }
            }
        });
        sync_rows(m, &mut self.pairs);
        samples.into_iter().for_each(sample);
        if let Some(e) = self.stage_error.take() {
            return Err(m.pore_fluid_cause(e, true));
        }
        check_state(m).map_err(|e| m.pore_fluid_cause(e, false))?;
        crate::plan::check_stages(m)
    }

    /// The model is the state: the stiffest contact is found on it directly, O(contacts).
    fn too_stiff(&mut self, m: &mut Model) -> Result<Option<StiffContact>> {
        Ok(too_stiff(m, &self.plan))
    }

    fn sync(&mut self, _: &mut Model) -> Result<()> {
        Ok(())
    }

    fn bytes(&self) -> usize {
        self.scratch_bytes()
    }
}

/// Wall-clock time spent in each named stage.
#[derive(Debug, Clone, Default)]
pub struct StageTimes(pub Vec<(Stage, std::time::Duration)>);

impl StageTimes {
    pub fn add(&mut self, stage: Stage, d: std::time::Duration) {
        match self.0.iter_mut().find(|(s, _)| *s == stage) {
            Some((_, t)) => *t += d,
            None => self.0.push((stage, d)),
        }
    }
}

fn record_breaks(m: &mut Model, breaks: Breaks) {
    for (i, j, kind) in breaks.0 {
        m.breakages.push(Breakage { step: m.clock.step, time: m.clock.time, i, j, kind });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::REGISTRY;

    /// A stage added to the registry without its CPU pass fails here; the heat ledger is booked
    /// inside the passes that dissipate.
    #[test]
    fn every_optional_stage_but_the_ledger_has_its_cpu_pass_listed_once_in_step_order() {
        for e in REGISTRY.iter().filter(|e| e.effect) {
            let listed = CPU_STAGES.iter().filter(|(s, _)| *s == e.stage).count();
            let expected = usize::from(e.role != Role::Ledger);
            assert_eq!(listed, expected, "{}: in CPU_STAGES {listed} time(s)", e.name);
        }
        let order: Vec<usize> =
            CPU_STAGES.iter().map(|(s, _)| Stage::ALL.iter().position(|a| a == s).unwrap()).collect();
        assert!(order.is_sorted(), "CPU_STAGES is in step order");
    }
}
