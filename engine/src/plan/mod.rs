//! The step plan: which stages and effects this scene needs, decided once before a run, and
//! the stage registry: one row per stage of a step ([`REGISTRY`]), in the order the stages run.
//! A row owns what the engine knows of its stage beyond the stage's own files — its name (the
//! files'), its place in a step (role), its plan switch, its lanes and their bytes, its checks,
//! where a checkpoint carries its state, how a script switches it on and how the plan words it.
//! [`Stage::ALL`], [`Stage::name`], [`Stage::role`], [`StepPlan::has`],
//! [`StepPlan::lane_sets`] and the plan's words read it, and both backends walk a plan's stages
//! in its order ([`StepPlan::runs`]): the order is written here, once. An effect's variant,
//! its row and its field of [`StepPlan`] sit in this one file.
//!
//! An effect that is off has no lane, no loop and no branch in a hot loop: the CPU backend
//! picks a loop monomorphised for the plan's laws. An optional effect's files are in
//! `effects/<name>/` (CPU pass `cpu.rs`, GPU kernel `gpu.rs`) beside `shaders/<name>.wgsl`;
//! the core's stages live in the backends. `tests/module_deps.rs` fails when a row's files, its
//! parity test or its checkpoint section are missing, and the host's tests when its script
//! switch is not in the script reference.

use crate::effects::applied_loads::AppliedLoadsPlan;
use crate::effects::buoyancy::BuoyancyPlan;
use crate::effects::clumps::ClumpsPlan;
use crate::effects::conduction::ConductionPlan;
use crate::effects::confining_pressure::ConfiningPlan;
use crate::effects::moisture::MoisturePlan;
use crate::effects::parallel_bond;
use crate::effects::parallel_bond::physics::ParallelBondParams;
use crate::effects::periodic::setting::Periodic;
use crate::effects::pore_flow::PoreFlowPlan;
use crate::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
use crate::error::Result;
use crate::model::{Model, NormalKind, TangentialKind};
use crate::physics::contact_law::PairParams;
use crate::physics::Vec3;
use crate::state::particles::HeatCauses;
use crate::walls::{Wall, WallMotion};
use std::fmt;
use std::mem::size_of;

mod pair_constants;
mod words;

pub use pair_constants::{pair_params, rigid_wall_params};
pub use words::PlanText;

/// The named stages of one time step, in the order they run ([`REGISTRY`] holds a
/// row per stage, in this order). A stage's name is its files': `shaders/<name>.wgsl` and,
/// for an optional effect, the folder `effects/<name>/` (CPU pass `cpu.rs`, GPU kernel
/// `gpu.rs`, where its name also labels the pipeline); a core stage's kernel is
/// `backend/gpu/<name>.rs` and its CPU twin `backend/cpu/<name>.rs` (which the CPU runs as one
/// fused pass on unobserved steps) or the engine-level `<name>.rs` or `<name>/` that both
/// backends share (walls, neighbours, guard).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Walls move: prescribed velocity, or servo control on the last step's load.
    Walls,
    /// Neighbour rows, rebuilt when the drift since the last build exceeds half the skin.
    Neighbours,
    /// Particle–particle contact forces (and torques), bonds and their breakage.
    ContactForces,
    /// Particle–wall contact forces and the loads the walls carry.
    WallForces,
    /// Optional: parallel bonds (Potyondy & Cundall 2004) in parallel with the linear
    /// contacts: their forces and moments, added to the contact sums, and their breakage. Its
    /// lanes (the bonds' rows and states) exist only in scenes that made such bonds.
    ParallelBond,
    /// Optional: rolling resistance (effects/rolling_resistance/physics.rs), a torque against the
    /// relative rolling of each contact, added to the contact and wall stages' torques from each
    /// particle's own row. Only the epsd model has lanes (a rolling spring per row entry and
    /// per wall contact).
    RollingResistance,
    /// Optional: pore density flow (paper 003 §3.3): the pore network follows the elements,
    /// the fluid flows between pores in sub-steps under its stable step, and each pore's
    /// pressure pushes the elements at its corners (effects/pore_flow/coupling.rs). A force stage.
    PoreFlow,
    /// Optional: applied loads, the external force and torque a script put on each element
    /// (`d.apply_force`, `d.apply_torque`), constant until changed, added to the force and torque
    /// lanes before integration (and before the buoyancy's drag, which reads their sum). Its lanes
    /// (effects/applied_loads/lanes.rs) exist only while some element carries a load.
    AppliedLoads,
    /// Optional: a confining pressure on the side of a cylindrical sample between two platens
    /// (a triaxial cell's membrane, effects/confining_pressure/): each step the grains the
    /// membrane touches are pushed towards the axis with the pressure times their patch. A force
    /// stage.
    ConfiningPressure,
    /// Optional: the water table's buoyancy −ρ_f·V_sub·g (and Stokes drag) on the elements
    /// below the level (effects/buoyancy/), a force stage: added to the force lane before integration,
    /// so local damping sees it.
    Buoyancy,
    /// Body forces, damping and leapfrog integration (rotation when on).
    Integrate,
    /// Optional: clumps (effects/clumps/), rigid bodies of elements: each clump's member loads
    /// summed, its body advanced and its members placed, right after the move (which leaves
    /// the members alone).
    Clumps,
    /// Optional: periodic boundaries (effects/periodic/): each element that left the cell comes
    /// back through the opposite face, after the move (pairs meet through their nearest image).
    Periodic,
    /// Optional: the energy ledger, the heat each particle releases by cause and the work
    /// walls do. Its lanes exist only in plans that keep it; the core stages book into them
    /// as they dissipate, because each cause is a by-product of a core law (see
    /// docs/adding-an-effect.md).
    HeatLedger,
    /// Optional: heat conduction between elements in contact or bonded, sources, fixed and
    /// insulated groups, thermal expansion of radii, every field step (effects/conduction/).
    Conduction,
    /// Optional: moisture diffusion between elements in contact or bonded (the diffusion core
    /// heat uses, its own conductances), evaporation, fixed and sealed groups, and the water
    /// content's coupling to radii and bond strengths, every field step (effects/moisture/).
    Moisture,
    /// The stability guard's checks, every `guard_every` steps.
    Guard,
}

/// Where a stage sits in a step, which decides how the backends run it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The core (walls, rows, contact and wall forces, integration): every plan runs it, fused
    /// on the CPU's unobserved steps.
    Core,
    /// An optional force stage: adds its loads after the core's forces and before the move,
    /// so a plan with one runs the core's passes apart.
    Force,
    /// An optional field stage: a field step after the move.
    Field,
    /// An optional stage that moves rigid bodies right after the move (clumps), before the
    /// field stages.
    Body,
    /// Booked inside the stages that dissipate (the heat ledger), no pass of its own.
    Ledger,
    /// The stability guard, every `guard_every` steps.
    Guard,
}

/// What the engine knows of one stage.
pub struct Entry {
    pub stage: Stage,
    /// Its files' name: `shaders/<name>.wgsl`, the GPU kernel and the CPU pass.
    pub name: &'static str,
    pub role: Role,
    /// An optional effect with a folder of its own, `effects/<name>/` (false: a core stage,
    /// in the backends).
    pub effect: bool,
    /// Whether a step of the plan runs the stage.
    pub runs: fn(&StepPlan) -> bool,
    /// The stage's own lanes in the plan, on the CPU (f64); none for a stage that keeps none.
    pub lanes: fn(&StepPlan) -> Option<LaneSet>,
    /// Where a checkpoint carries the stage's state: `effects.<name>` (its state in the model's
    /// `effects`, a section by its name), `Section::<Variant>` (a section of its own) or
    /// `record.<field>` (a field of the checkpoint's record); "" for a stage whose state is the
    /// core's or is derived again on load.
    pub checkpoint: &'static str,
    /// How a script switches the stage on ("" for the core's, which always run).
    pub script: &'static str,
    /// The stage with its parameters in the plan's words, when the plan runs it (none for the
    /// core's, which the plan words itself, and the heat ledger, whose lanes say it all).
    pub words: fn(&StepPlan) -> Option<String>,
    /// What the plan's `not simulated:` list calls the effect when the plan does not run it
    /// ("" for the core's stages, which the plan words itself).
    pub off: &'static str,
    /// The stage's checks of the model before and during a run (a field stage's stable
    /// sub-step), which [`check_stages`] runs; `Ok` when the scene has the stage off.
    pub check: fn(&Model) -> Result<()>,
    /// How `d.enable(name)` and `d.disable(name)` switch the effect, for one a script switches
    /// by name.
    pub switch: Option<Switch>,
}

/// An effect a script switches by name: `d.enable(name)`, `d.disable(name)`.
#[derive(Clone, Copy)]
pub struct Switch {
    /// The script's name for it (`"heat"` for the conduction stage).
    pub name: &'static str,
    /// On, with its lanes allocated (`None`: another call switches it on, `d.water_level`).
    pub enable: Option<fn(&mut Model) -> Result<()>>,
    /// Off: the plan drops the stage (a field's lanes stay, and a later enable continues from
    /// them).
    pub disable: fn(&mut Model),
}

/// A stage without checks of its own.
fn unchecked(_: &Model) -> Result<()> {
    Ok(())
}

/// Every stage's checks of the model ([`Entry::check`]), in step order: the guard runs them
/// before a run and the CPU backend after each batch.
pub fn check_stages(m: &Model) -> Result<()> {
    REGISTRY.iter().try_for_each(|e| (e.check)(m))
}

const fn core(stage: Stage, name: &'static str, runs: fn(&StepPlan) -> bool) -> Entry {
    let role = if matches!(stage, Stage::Guard) { Role::Guard } else { Role::Core };
    Entry {
        stage,
        name,
        role,
        effect: false,
        runs,
        lanes: |_| None,
        checkpoint: "",
        script: "",
        words: |_| None,
        off: "",
        check: unchecked,
        switch: None,
    }
}

/// A lane set of per-particle lanes only.
fn per_particle(stage: Stage, lanes: Vec<&'static str>, bytes: usize) -> LaneSet {
    LaneSet { stage: stage.name(), lanes, bytes_per_particle: bytes, bytes_per_entry: 0, bytes_per_row_entry: 0 }
}

/// Every stage, in step order.
pub const REGISTRY: [Entry; 17] = [
    core(Stage::Walls, "walls", |p| p.walls > 0),
    core(Stage::Neighbours, "neighbours", |_| true),
    core(Stage::ContactForces, "contact_forces", |_| true),
    core(Stage::WallForces, "wall_forces", |p| p.walls > 0),
    Entry {
        stage: Stage::ParallelBond,
        name: "parallel_bond",
        role: Role::Force,
        effect: true,
        runs: |p| p.parallel_bond.is_some(),
        // One row start per particle; per bond entry the partner and the state.
        lanes: |p| {
            p.parallel_bond.map(|_| LaneSet {
                stage: Stage::ParallelBond.name(),
                lanes: vec!["row_start", "other", "shear", "normal", "bending", "twist", "status"],
                bytes_per_particle: size_of::<u32>(),
                bytes_per_entry: crate::effects::parallel_bond::lanes::ParallelBonds::ENTRY_BYTES,
                bytes_per_row_entry: 0,
            })
        },
        checkpoint: "record.parallel_bonds",
        script: "d.bond_parallel",
        words: |p| p.parallel_bond.as_ref().map(|b| parallel_bond::words(b, p.parallel_bond_entries / 2)),
        off: "parallel bonds",
        check: unchecked,
        switch: None,
    },
    Entry {
        stage: Stage::RollingResistance,
        name: "rolling_resistance",
        role: Role::Force,
        effect: true,
        runs: |p| p.rolling.is_some(),
        // epsd: a rolling spring per row entry, and one per particle and wall; cdt keeps none.
        lanes: |p| {
            let v = size_of::<Vec3>();
            p.rolling.filter(|r| r.model == RollingModel::Epsd).map(|_| LaneSet {
                stage: Stage::RollingResistance.name(),
                lanes: vec!["rolling_spring", "wall_rolling_spring"],
                bytes_per_particle: p.walls * v,
                bytes_per_entry: 0,
                bytes_per_row_entry: v,
            })
        },
        checkpoint: "Section::Rolling",
        script: "d.rolling_resistance",
        words: |p| p.rolling.as_ref().map(RollingResistance::words),
        off: "rolling resistance",
        check: unchecked,
        switch: Some(Switch { name: "rolling_resistance", enable: None, disable: |m| m.settings.rolling = None }),
    },
    Entry {
        stage: Stage::PoreFlow,
        name: "pore_flow",
        role: Role::Force,
        effect: true,
        runs: |p| p.pore_flow.is_some(),
        // The pore network's lanes are per pore and per throat, not per particle: the plan's
        // words give their bytes (`PoreFlowPlan`).
        lanes: |_| None,
        checkpoint: "Section::PoreFlow",
        script: "d.enable(\"pore_flow\")",
        words: |p| p.pore_flow.as_ref().map(PoreFlowPlan::words),
        off: "fluid flow",
        check: unchecked,
        switch: Some(Switch {
            name: "pore_flow",
            enable: Some(Model::enable_pore_flow),
            disable: Model::disable_pore_flow,
        }),
    },
    Entry {
        stage: Stage::AppliedLoads,
        name: "applied_loads",
        role: Role::Force,
        effect: true,
        runs: |p| p.applied_loads.is_some(),
        lanes: |p| {
            let (v, f) = (size_of::<Vec3>(), size_of::<f64>());
            p.applied_loads.map(|_| {
                let lanes = vec!["applied_force", "applied_torque", "applied_work_offset"];
                per_particle(Stage::AppliedLoads, lanes, 2 * v + f)
            })
        },
        checkpoint: "Section::AppliedLoads",
        script: "d.apply_force",
        words: |p| p.applied_loads.as_ref().map(AppliedLoadsPlan::words),
        off: "applied loads",
        check: unchecked,
        switch: None,
    },
    Entry {
        stage: Stage::ConfiningPressure,
        name: "confining_pressure",
        role: Role::Force,
        effect: true,
        runs: |p| p.confining.is_some(),
        // It reads the core's lanes and keeps none per particle (the GPU three words per cell).
        lanes: |_| None,
        checkpoint: "effects.confining_pressure",
        script: "d.confine",
        words: |p| p.confining.as_ref().map(ConfiningPlan::words),
        off: "confining pressure",
        check: unchecked,
        switch: None,
    },
    Entry {
        stage: Stage::Buoyancy,
        name: "buoyancy",
        role: Role::Force,
        effect: true,
        runs: |p| p.buoyancy.is_some(),
        // It reads the core's lanes and keeps none of its own.
        lanes: |_| None,
        checkpoint: "record.water",
        script: "d.water_level",
        words: |p| p.buoyancy.as_ref().map(BuoyancyPlan::words),
        off: "buoyancy",
        check: unchecked,
        switch: Some(Switch { name: "water", enable: None, disable: |m| m.set_water_level(None) }),
    },
    core(Stage::Integrate, "integrate", |_| true),
    Entry {
        stage: Stage::Clumps,
        name: "clumps",
        role: Role::Body,
        effect: true,
        runs: |p| p.clumps.is_some(),
        // Per element its clump; per member its number and offset, and its share of its
        // body: counted on every element, a bound (a scene of clumps is mostly members).
        lanes: |p| {
            p.clumps.map(|c| {
                let body = size_of::<crate::effects::clumps::lanes::Body>() * c.clumps;
                let member = size_of::<u32>() + size_of::<Vec3>() + body.div_ceil(c.members.max(1));
                per_particle(Stage::Clumps, vec!["clump_of", "member", "offset", "body"], size_of::<u32>() + member)
            })
        },
        checkpoint: "Section::Clumps",
        script: "d.clump",
        words: |p| p.clumps.as_ref().map(ClumpsPlan::words),
        off: "clumps",
        check: unchecked,
        switch: None,
    },
    Entry {
        stage: Stage::Periodic,
        name: "periodic",
        role: Role::Body,
        effect: true,
        runs: |p| p.periodic.is_some(),
        // It moves the core's lanes and keeps none of its own.
        lanes: |_| None,
        checkpoint: "effects.periodic",
        script: "d.periodic",
        words: |p| p.periodic.as_ref().map(crate::effects::periodic::words),
        off: "periodic cell",
        check: unchecked,
        switch: None,
    },
    Entry {
        stage: Stage::HeatLedger,
        name: "heat_ledger",
        role: Role::Ledger,
        effect: true,
        runs: |p| p.heat.lanes() > 0,
        lanes: |p| {
            (p.heat.lanes() > 0)
                .then(|| per_particle(Stage::HeatLedger, p.heat.names(), p.heat.lanes() * size_of::<f64>()))
        },
        checkpoint: "record.model",
        script: "d.heat_ledger",
        words: |_| None,
        off: "heat ledger",
        check: unchecked,
        switch: None,
    },
    Entry {
        stage: Stage::Conduction,
        name: "conduction",
        role: Role::Field,
        effect: true,
        runs: |p| p.conduction.is_some(),
        lanes: |p| p.conduction.as_ref().map(|c| per_particle(Stage::Conduction, c.lanes(), c.bytes_per_particle())),
        checkpoint: "record.thermal",
        script: "d.enable(\"heat\")",
        words: |p| p.conduction.as_ref().map(ConductionPlan::words),
        off: "heat conduction",
        check: Model::check_conduction,
        switch: Some(Switch {
            name: "heat",
            enable: Some(|m| {
                m.enable_heat();
                Ok(())
            }),
            disable: |m| m.settings.heat.enabled = false,
        }),
    },
    Entry {
        stage: Stage::Moisture,
        name: "moisture",
        role: Role::Field,
        effect: true,
        runs: |p| p.moisture.is_some(),
        lanes: |p| p.moisture.as_ref().map(|w| per_particle(Stage::Moisture, w.lanes(), w.bytes_per_particle())),
        checkpoint: "effects.moisture",
        script: "d.enable(\"moisture\")",
        words: |p| p.moisture.as_ref().map(MoisturePlan::words),
        off: "moisture",
        check: Model::check_moisture,
        switch: Some(Switch {
            name: "moisture",
            enable: Some(|m| {
                m.enable_moisture();
                Ok(())
            }),
            disable: |m| m.effects.moisture.settings.enabled = false,
        }),
    },
    core(Stage::Guard, "guard", |_| true),
];

// A row's position is its stage's discriminant, so `Stage::name` and `role` index the table.
const _: () = {
    let mut k = 0;
    while k < REGISTRY.len() {
        assert!(REGISTRY[k].stage as usize == k, "the registry's rows are in the order of `Stage`'s variants");
        k += 1;
    }
};

/// The registry as a slice that lives for the program.
const ROWS: &[Entry] = &REGISTRY;

impl Stage {
    /// Every stage, in step order.
    pub const ALL: [Stage; REGISTRY.len()] = {
        let mut all = [Stage::Walls; REGISTRY.len()];
        let mut k = 0;
        while k < all.len() {
            all[k] = REGISTRY[k].stage;
            k += 1;
        }
        all
    };

    /// The stage's row of the registry.
    pub const fn entry(self) -> &'static Entry {
        &ROWS[self as usize]
    }

    /// The stage's name, as its files are named.
    pub const fn name(self) -> &'static str {
        self.entry().name
    }

    /// Where the stage sits in a step.
    pub const fn role(self) -> Role {
        self.entry().role
    }
}

/// A set of stages, walked in step order ([`StepPlan::runs`]): bit k is `Stage::ALL[k]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stages(u32);

impl Iterator for Stages {
    type Item = Stage;
    fn next(&mut self) -> Option<Stage> {
        if self.0 == 0 {
            return None;
        }
        let k = self.0.trailing_zeros() as usize;
        self.0 &= self.0 - 1;
        Some(Stage::ALL[k])
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Debug, Clone)]
pub struct StepPlan {
    pub normal: NormalKind,
    pub tangential: TangentialKind,
    /// Any material asks for a contact dashpot (restitution < 1).
    pub dashpot: bool,
    pub rotation: bool,
    pub gravity: bool,
    /// Global viscous damping ratio (0 = off).
    pub damping: f64,
    /// Local (Cundall) damping coefficient (0 = off).
    pub local_damping: f64,
    /// Bonded pairs exist.
    pub bonds: bool,
    pub walls: usize,
    pub moving_walls: usize,
    pub servo_walls: usize,
    /// Bit w: wall w is a servo, steered each step by its load of the step before (the only
    /// wall loads a step reads; the others are read after a run).
    pub servo_mask: u32,
    pub materials: usize,
    /// Pair constants per (material, material): `pair[a * materials + b]`.
    pub pair: Vec<PairParams>,
    /// Constants of a particle of each material against each wall: `wall[w * materials + a]`.
    pub wall: Vec<PairParams>,
    /// The heat ledger's causes this plan books (all off without the ledger).
    pub heat: HeatCauses,
    /// The parallel bonds' parameters when the scene has them (the `parallel_bond` stage).
    pub parallel_bond: Option<ParallelBondParams>,
    /// Parallel-bond row entries (two per bond), for the lanes' account.
    pub parallel_bond_entries: usize,
    /// Heat conduction (the scene enables heat).
    pub conduction: Option<ConductionPlan>,
    /// Moisture diffusion (the scene enables moisture).
    pub moisture: Option<MoisturePlan>,
    /// The water table's buoyancy (the scene sets a level).
    pub buoyancy: Option<BuoyancyPlan>,
    /// Rolling resistance (the scene sets one with μ_r > 0).
    pub rolling: Option<RollingResistance>,
    /// Pore density flow (the scene enables it).
    pub pore_flow: Option<PoreFlowPlan>,
    /// Applied loads (some element carries an applied force or torque).
    pub applied_loads: Option<AppliedLoadsPlan>,
    /// A confining pressure on a cylindrical sample (the scene confines one).
    pub confining: Option<ConfiningPlan>,
    /// A 2D model's plate thickness (m): the scene lies in the x–z plane (`crate::planar`).
    pub planar: Option<f64>,
    /// Rigid clumps of elements (the scene made some).
    pub clumps: Option<ClumpsPlan>,
    /// The periodic cell (the scene has periodic axes).
    pub periodic: Option<Periodic>,
}

/// One stage's per-particle lanes in a plan, on the CPU backend (f64).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LaneSet {
    pub stage: &'static str,
    pub lanes: Vec<&'static str>,
    pub bytes_per_particle: usize,
    /// Bytes per row entry of a stage with per-pair lanes (0 for the others): the
    /// `parallel_bond` stage's bonds, two entries each.
    pub bytes_per_entry: usize,
    /// Bytes per neighbour-row entry (0 for the others): the epsd rolling springs, aligned
    /// with the contact rows.
    pub bytes_per_row_entry: usize,
}

impl StepPlan {
    pub fn build(m: &Model) -> Self {
        let nm = m.materials.len();
        let mut pair = Vec::with_capacity(nm * nm);
        for a in &m.materials {
            for b in &m.materials {
                pair.push(pair_params(a, b));
            }
        }
        let mut wall = Vec::with_capacity(m.walls.len() * nm);
        for w in &m.walls {
            for a in &m.materials {
                let mut p = rigid_wall_params(a);
                if let Some(mu) = w.friction {
                    p.mu = mu;
                }
                wall.push(p);
            }
        }
        let s = &m.settings;
        let shear_springs = s.tangential.is_mindlin() || pair.iter().chain(&wall).any(|p| p.ks > 0.0);
        let moving_walls = m.walls.iter().filter(|w| matches!(w.motion, WallMotion::Velocity(_))).count();
        let servo = |w: &Wall| matches!(w.motion, WallMotion::Servo { .. });
        let servo_walls = m.walls.iter().filter(|w| servo(w)).count();
        let servo_mask = m.walls.iter().enumerate().filter(|(_, w)| servo(w)).fold(0, |mask, (k, _)| mask | 1 << k);
        let bonds = m.contacts.state.iter().any(|p| p.bonded);
        let pb = &m.parallel_bonds;
        let parallel_bond = pb.params.filter(|_| pb.intact() > 0);
        let dashpot = m.materials.iter().any(|a| a.restitution < 1.0);
        // μ_r = 0 resists nothing: no stage.
        let rolling = s.rolling.filter(|r| r.mu_r > 0.0);
        let heat = if s.heat_ledger {
            HeatCauses {
                // The water's drag is a damping too (the buoyancy stage books its heat here).
                damping: s.damping > 0.0
                    || s.local_damping > 0.0
                    || (s.water.level.is_some() && s.water.viscosity > 0.0),
                contact_damping: dashpot,
                // Rolling resistance is friction too (its stage books its torques' work here).
                friction: shear_springs || rolling.is_some(),
                breakage: bonds || parallel_bond.is_some(),
                // A fixed wall does no work.
                wall_work: moving_walls + servo_walls > 0,
            }
        } else {
            HeatCauses::default()
        };
        let applied_loads = AppliedLoadsPlan::of(m);
        StepPlan {
            normal: s.normal,
            tangential: s.tangential,
            dashpot,
            // Parallel bonds carry moments, rolling resistance and an applied torque are torques:
            // they need the particles to turn.
            rotation: s.rotation
                || parallel_bond.is_some()
                || rolling.is_some()
                || applied_loads.is_some_and(|a| a.torques),
            gravity: s.gravity.norm() > 0.0,
            damping: s.damping,
            local_damping: s.local_damping,
            bonds,
            walls: m.walls.len(),
            moving_walls,
            servo_walls,
            servo_mask,
            materials: nm,
            pair,
            wall,
            heat,
            parallel_bond,
            parallel_bond_entries: if parallel_bond.is_some() { pb.other.len() } else { 0 },
            conduction: ConductionPlan::of(m),
            moisture: MoisturePlan::of(m),
            buoyancy: BuoyancyPlan::of(m),
            rolling,
            pore_flow: PoreFlowPlan::of(m),
            applied_loads,
            confining: ConfiningPlan::of(m),
            planar: m.settings.planar.map(|p| p.thickness),
            clumps: ClumpsPlan::of(m),
            periodic: m.effects.periodic.cell,
        }
    }

    /// The stages a step of this plan runs, in order: the wall stages only with walls, each
    /// optional stage only when the plan has it.
    pub fn stages(&self) -> Vec<Stage> {
        Stage::ALL.into_iter().filter(|s| self.has(*s)).collect()
    }

    /// Whether a step of this plan runs `stage`.
    pub fn has(&self, stage: Stage) -> bool {
        (stage.entry().runs)(self)
    }

    /// The per-particle lanes this plan allocates on the CPU, by stage: the core's, then each
    /// optional lane set the plan has (rotation, heat). The GPU allocates the same sets, in
    /// f32 (`backend::gpu::memory`).
    pub fn lane_sets(&self) -> Vec<LaneSet> {
        use std::mem::size_of;
        let (v, f, u) = (size_of::<Vec3>(), size_of::<f64>(), size_of::<u32>());
        let mut sets = vec![LaneSet {
            stage: "core",
            lanes: vec!["pos", "vel", "force", "origin", "radius", "mass", "material", "fixed"],
            bytes_per_particle: 4 * v + 2 * f + u + 1,
            bytes_per_entry: 0,
            bytes_per_row_entry: 0,
        }];
        if self.rotation {
            sets.push(LaneSet {
                stage: "rotation",
                lanes: vec!["ang_vel", "torque", "angle"],
                bytes_per_particle: 3 * v,
                bytes_per_entry: 0,
                bytes_per_row_entry: 0,
            });
        }
        sets.extend(REGISTRY.iter().filter_map(|e| (e.lanes)(self)));
        sets
    }

    /// Bytes per particle of the plan's lanes on the CPU ([`lane_sets`](Self::lane_sets)).
    pub fn bytes_per_particle(&self) -> usize {
        self.lane_sets().iter().map(|s| s.bytes_per_particle).sum()
    }

    /// Bytes of the plan's per-pair lanes on the CPU (the parallel bonds' row entries).
    pub fn pair_bytes(&self) -> usize {
        self.lane_sets().iter().map(|s| s.bytes_per_entry).sum::<usize>() * self.parallel_bond_entries
    }

    /// Bytes of the plan's lanes per neighbour-row entry on the CPU, beyond the rows' own (the
    /// epsd rolling springs).
    pub fn row_entry_bytes(&self) -> usize {
        self.lane_sets().iter().map(|s| s.bytes_per_row_entry).sum()
    }

    /// Whether a force stage runs between the core's forces and the move (parallel bonds,
    /// rolling resistance, pore flow, applied loads, buoyancy): the CPU then runs the core's
    /// passes apart instead of fused.
    pub fn has_force_stage(&self) -> bool {
        self.runs(Role::Force).next().is_some()
    }

    /// Whether the plan has walls and none of them moves (by velocity or servo).
    pub fn fixed_walls_only(&self) -> bool {
        self.walls > 0 && self.moving_walls + self.servo_walls == 0
    }

    /// The stages of `role` this plan runs, in step order. A set apart from the plan, so a
    /// backend may walk it while it borrows itself mutably, and allocates nothing.
    pub fn runs(&self, role: Role) -> Stages {
        let bits = Stage::ALL.iter().enumerate().filter(|(_, s)| s.role() == role && self.has(**s));
        Stages(bits.fold(0, |set, (k, _)| set | 1 << k))
    }

    /// Each particle's coefficient of MatDEM's global viscous damping, c_i = 2·ζ·√(m_i·k_i)
    /// (N·s/m) with k_i the element's stiffness; empty when the plan has no viscous damping.
    /// Both backends take theirs from here (the GPU as c_i/m_i).
    pub fn damping_coefficients(&self, m: &Model) -> Vec<f64> {
        if self.damping > 0.0 {
            (0..m.len()).map(|i| 2.0 * self.damping * (m.particles.mass[i] * m.element_stiffness(i)).sqrt()).collect()
        } else {
            Vec::new()
        }
    }

    #[inline(always)]
    pub fn pair(&self, a: u32, b: u32) -> &PairParams {
        &self.pair[a as usize * self.materials + b as usize]
    }

    /// Constants of a particle of `material` against wall `w`.
    #[inline(always)]
    pub fn wall_pair(&self, w: usize, material: u32) -> &PairParams {
        &self.wall[w * self.materials + material as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::Material;
    use crate::walls::Wall;
    use crate::Vec3;

    #[test]
    fn a_plan_runs_the_wall_stages_only_with_walls() {
        let mut m = Model::new();
        let k = m.add_material(Material::from_micro("m", 2650.0, 1e6, 1e5, 0.0, 0.0, 0.5, 1e-3).unwrap()).unwrap();
        m.add_particle(Vec3::zeros(), 1e-3, k).unwrap();
        // The optional stages are another test's (stage_lanes.rs): the core's here.
        m.settings.heat_ledger = false;
        let names = |m: &Model| StepPlan::build(m).stages().iter().map(|s| s.name()).collect::<Vec<_>>().join(" ");
        assert_eq!(names(&m), "neighbours contact_forces integrate guard");
        m.add_wall(Wall::plane("floor", Vec3::new(0.0, 0.0, -1e-3), Vec3::z(), 1e-4).unwrap()).unwrap();
        assert_eq!(names(&m), "walls neighbours contact_forces wall_forces integrate guard");
        assert_eq!(
            StepPlan::build(&m).runs(Role::Core).collect::<Vec<_>>(),
            [Stage::Walls, Stage::Neighbours, Stage::ContactForces, Stage::WallForces, Stage::Integrate]
        );
        assert_eq!(StepPlan::build(&m).runs(Role::Force).next(), None);
    }

    /// The backends walk the stages by role in `Stage::ALL`'s order, so the roles must follow
    /// the step: the contact and wall forces, then every force stage, the move, then every
    /// field stage.
    #[test]
    fn the_roles_follow_the_step_order() {
        let at = |s: Stage| Stage::ALL.iter().position(|x| *x == s).unwrap();
        for s in Stage::ALL {
            match s.role() {
                Role::Force => assert!(at(Stage::WallForces) < at(s) && at(s) < at(Stage::Integrate), "{s}"),
                Role::Body => assert!(at(Stage::Integrate) < at(s) && at(s) <= at(Stage::Integrate) + 2, "{s}"),
                Role::Field => assert!(at(Stage::Integrate) < at(s) && at(s) < at(Stage::Guard), "{s}"),
                Role::Core | Role::Ledger | Role::Guard => {}
            }
        }
        // A set walks in that order whatever order its bits were set in.
        let set = Stages(1 << at(Stage::Moisture) | 1 << at(Stage::Walls) | 1 << at(Stage::Buoyancy));
        assert_eq!(set.collect::<Vec<_>>(), [Stage::Walls, Stage::Buoyancy, Stage::Moisture]);
    }
}
