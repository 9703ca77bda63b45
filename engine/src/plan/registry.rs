//! The stage registry: one row per stage of a step, in the order the stages run. A row owns
//! what the engine knows of its stage beyond the stage's own files — its name (the files'),
//! its place in a step (role), its plan switch, its lanes and their bytes, where a checkpoint
//! carries its state, how a script switches it on and how the plan words it. [`Stage::ALL`],
//! [`Stage::name`], [`Stage::role`], [`StepPlan::has`], [`StepPlan::lane_sets`] and the plan's
//! words read it, and both backends walk a plan's stages in its order ([`StepPlan::runs`]): the
//! order is written here, once.
//!
//! An optional effect's files are in `effects/<name>/` (CPU pass `cpu.rs`, GPU kernel `gpu.rs`)
//! beside `shaders/<name>.wgsl`; the core's stages live in the backends. `tests/module_deps.rs`
//! fails when a row's files, its parity test or its checkpoint section are missing, and the
//! host's tests when its script switch is not in the script reference.

use super::{LaneSet, Role, Stage, StepPlan};
use crate::effects::applied_loads::AppliedLoadsPlan;
use crate::effects::buoyancy::BuoyancyPlan;
use crate::effects::clumps::ClumpsPlan;
use crate::effects::conduction::ConductionPlan;
use crate::effects::confining_pressure::ConfiningPlan;
use crate::effects::moisture::MoisturePlan;
use crate::effects::parallel_bond;
use crate::effects::pore_flow::PoreFlowPlan;
use crate::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
use crate::physics::Vec3;
use std::mem::size_of;

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
    /// Where a checkpoint carries the stage's state: `Section::<Variant>` (a section of its
    /// own) or `record.<field>` (a field of the checkpoint's record); "" for a stage whose
    /// state is the core's or is derived again on load.
    pub checkpoint: &'static str,
    /// How a script switches the stage on ("" for the core's, which always run).
    pub script: &'static str,
    /// The stage with its parameters in the plan's words, when the plan runs it (none for the
    /// core's, which the plan words itself, and the heat ledger, whose lanes say it all).
    pub words: fn(&StepPlan) -> Option<String>,
    /// What the plan's `not simulated:` list calls the effect when the plan does not run it
    /// ("" for the core's stages, which the plan words itself).
    pub off: &'static str,
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
    },
    Entry {
        stage: Stage::ConfiningPressure,
        name: "confining_pressure",
        role: Role::Force,
        effect: true,
        runs: |p| p.confining.is_some(),
        // It reads the core's lanes and keeps none per particle (the GPU three words per cell).
        lanes: |_| None,
        checkpoint: "Section::Confinement",
        script: "d.confine",
        words: |p| p.confining.as_ref().map(ConfiningPlan::words),
        off: "confining pressure",
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
    },
    Entry {
        stage: Stage::Periodic,
        name: "periodic",
        role: Role::Body,
        effect: true,
        runs: |p| p.periodic.is_some(),
        // It moves the core's lanes and keeps none of its own.
        lanes: |_| None,
        checkpoint: "Section::Periodic",
        script: "d.periodic",
        words: |p| p.periodic.as_ref().map(crate::effects::periodic::words),
        off: "periodic cell",
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
    },
    Entry {
        stage: Stage::Moisture,
        name: "moisture",
        role: Role::Field,
        effect: true,
        runs: |p| p.moisture.is_some(),
        lanes: |p| p.moisture.as_ref().map(|w| per_particle(Stage::Moisture, w.lanes(), w.bytes_per_particle())),
        checkpoint: "Section::Moisture",
        script: "d.enable(\"moisture\")",
        words: |p| p.moisture.as_ref().map(MoisturePlan::words),
        off: "moisture",
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
