//! An optional stage's pass on the CPU, as one object per plan: the pass and the scratch it keeps
//! between steps. The effect's `cpu.rs` builds its [`CpuStage`] for a plan that runs it (its
//! `stage`, a [`Build`]); the backend lists the builds once (`CPU_STAGES` in `mod.rs`) and runs
//! each plan's stages in the registry's order at their role's place in the step, so such a stage
//! names nothing else in the backend.

use crate::backend::cpu::contact_forces::Breaks;
use crate::backend::cpu::integrate::Observed;
use crate::error::Result;
use crate::model::Model;
use crate::plan::StepPlan;

/// One plan's pass of a stage.
pub trait CpuStage: Send {
    /// Runs the pass once, in the step (`Role::Force` between the core's forces and the move,
    /// `Role::Body` right after the move, `Role::Field` after the bodies).
    fn run(&mut self, m: &mut Model, input: &StageInput) -> Result<Booked>;
    /// Heap bytes of the scratch it keeps between steps.
    fn scratch_bytes(&self) -> usize {
        0
    }
}

/// What the backend hands every pass.
pub struct StageInput<'a> {
    pub plan: &'a StepPlan,
    /// c_i = 2·ζ·√(m_i·k_i) of the viscous damping; empty when it is off.
    pub damping_c: &'a [f64],
}

/// What a pass gives back for the backend to book.
#[derive(Default)]
pub struct Booked {
    /// Bonds that broke in the pass, recorded in the model's breakage list at this step.
    pub breaks: Breaks,
    /// A body stage's share of an observed step's kinetic energy and damping heat; a force
    /// stage's drag heat (buoyancy's), which the energies book apart.
    pub observed: Observed,
}

/// Builds a stage's pass for a plan that runs it (`StepPlan::has`).
pub type Build = fn(plan: &StepPlan) -> Option<Box<dyn CpuStage>>;

/// A pass with no scratch of its own: a function of the model and the plan.
struct Pass(fn(&mut Model, &StageInput) -> Result<Booked>);

impl CpuStage for Pass {
    fn run(&mut self, m: &mut Model, input: &StageInput) -> Result<Booked> {
        (self.0)(m, input)
    }
}

/// A stage whose pass keeps no scratch (the backend builds it only for a plan that runs it).
pub fn pass(f: fn(&mut Model, &StageInput) -> Result<Booked>) -> Option<Box<dyn CpuStage>> {
    Some(Box::new(Pass(f)))
}

/// A pass that keeps one f64 per particle between steps (a field stage's next values, kept so
/// that a step allocates nothing), with the plan it was built for.
struct Buffered<P> {
    plan: P,
    next: Vec<f64>,
    pass: fn(&mut Model, &P, &mut Vec<f64>),
}

impl<P: Send> CpuStage for Buffered<P> {
    fn run(&mut self, m: &mut Model, _: &StageInput) -> Result<Booked> {
        (self.pass)(m, &self.plan, &mut self.next);
        Ok(Booked::default())
    }

    fn scratch_bytes(&self) -> usize {
        self.next.capacity() * std::mem::size_of::<f64>()
    }
}

/// A stage whose pass keeps one f64 per particle between steps.
pub fn buffered<P: Send + 'static>(plan: P, pass: fn(&mut Model, &P, &mut Vec<f64>)) -> Box<dyn CpuStage> {
    Box::new(Buffered { plan, next: Vec::new(), pass })
}
