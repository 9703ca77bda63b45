//! The GPU backend: the CPU backend's stages as WGSL compute kernels (wgpu), in f32.
//!
//! A run uploads the model once, steps it on the device in batches of command buffers, and
//! brings back only what the host needs: between batches a few counters (the largest drift
//! and speed, the guard's findings), at the end of the run the state a script reads; the
//! next run continues on the device when the model is as that sync left it ([`Resident`]). One
//! step dispatches, in order: walls (last step's loads summed, then moved) → contact forces →
//! wall forces → parallel bonds, rolling resistance, pore flow, applied loads, buoyancy (when the
//! scene has them) → integration (inside the wall pass when none of those runs); when the drift
//! reaches half the skin the rows are rebuilt on the device ([`rows`]). The pore network's
//! topology is built on the host and rebuilt through it ([`pore_flow`]). Pipelines are built once per plan, with the plan's laws as pipeline
//! constants; stages the scene does not need (walls) are neither built nor dispatched, and
//! lanes it does not need (rotation, the dashpot force, heat causes it cannot produce) are
//! 128-byte placeholders or absent. Rows live in fixed-width slots, and the per-entry lanes
//! are split into slabs that each fit one storage binding ([`memory`]), so a model is
//! refused only when a single lane truly cannot fit.
//!
//! Deterministic: each particle sums its own row and writes only its own lanes; wall loads
//! are reduced in a fixed tree order; rows are sorted after they are collected; the only
//! atomics count integers (breakage events, sorted on the host; drift maxima; guard minima;
//! cell list counts). Two runs give the same bits, however the lanes are split.
//!
//! Heat is booked on the device by cause, as the CPU books it (each row half of every pair's
//! heat), into compensated f32 sums that each download adds to the model's f64 ledger
//! ([`heat_ledger`]).
//!
//! Not done on the device (the host keeps them): the first rows of a run (built at upload,
//! when the model is on the host anyway), a row build whose rows outgrow their slots or carry
//! more than [`memory::MAX_CARRY`] contacts and bonds (the host builds those and lays the
//! slots out wider; [`RowStats`] counts them), and energy samples (the state comes back to
//! the host for each sample).

pub mod bindings;
pub mod buffers;
pub mod contact_forces;
pub mod device;
pub mod device_stage;
pub mod guard;
pub mod integrate;
pub mod memory;
pub mod neighbours;
pub mod profile;
pub mod row_slots;
pub mod rows;
pub mod shaders;
pub mod wall_forces;
pub mod walls;

// The effects held by name (the others are rows of `DEVICE_STAGES`).
use crate::effects;
use crate::effects::conduction::gpu as conduction;
use crate::effects::heat_ledger::gpu as heat_ledger;
use crate::effects::periodic::gpu as periodic;
use crate::effects::pore_flow::gpu as pore_flow;

use super::{Backend, Sampling};
use crate::effects::rolling_resistance::physics::RollingModel;
use crate::error::{Error, GpuError, Result};
use crate::guard::StiffContact;
use crate::model::{Breakage, Model};
use crate::neighbours::{is_stale, rebuild, rebuild_wall_mask, steps_until_rebuild, steps_until_rebuild_sheared};
use crate::physics::contact_law::BreakKind;
use crate::physics::Vec3;
use crate::plan::REGISTRY;
use crate::plan::{Stage, StepPlan};
use crate::status::{kinetic_energy, potential_energies, EnergySample};
use buffers::{
    download, read, DeviceLanes, HostLanes, Params, COUNTERS, C_CROWDED, C_DRIFT, C_EVENTS, C_GUARD, C_LONGEST,
    C_PORE_DRIFT, C_PORE_EXCHANGE, C_PORE_STEP, C_SPEED, C_STIFF,
};
use device::GpuContext;
use device_stage::{DeviceStages, UploadContext};
use shaders::{Kernel, Pipeline};
use std::sync::{Arc, Mutex};

pub use device::{select, BackendChoice, Compute};

/// The core's WGSL stages and those of the effects held by name.
const HELD_SHADERS: [&shaders::Shader; 13] = [
    &shaders::NEIGHBOURS,
    &shaders::CELL_LIST,
    &shaders::SCAN,
    &shaders::ROWS,
    &shaders::CONTACT_FORCES,
    &shaders::WALL_FORCES,
    &shaders::WALLS,
    &shaders::INTEGRATE,
    &shaders::WALL_FORCES_INTEGRATE,
    &shaders::GUARD,
    &periodic::SHADER,
    &pore_flow::SHADER,
    &pore_flow::heat::SHADER,
];

/// The rows of [`DEVICE_STAGES`] from the effects' list (`effects::with_device_stages!`).
macro_rules! device_stages {
    ($($stage:ident $name:ident,)*) => {
        /// The optional stages an upload builds through their `gpu.rs` (`device_stage`): the
        /// stage, its WGSL and its `upload`, in step order, which is also the order they are
        /// built and downloaded in. Each step dispatches them in the plan's order.
        const DEVICE_STAGES: &[(Stage, &shaders::Shader, device_stage::Upload)] =
            &[$((Stage::$stage, &effects::$name::gpu::SHADER, effects::$name::gpu::upload),)*];
    };
}
crate::with_device_stages!(device_stages);

/// Every WGSL stage, the core's and the effects', for validation without a device
/// (`shaders.rs`'s tests).
pub fn all_shaders() -> impl Iterator<Item = &'static shaders::Shader> {
    HELD_SHADERS.into_iter().chain(DEVICE_STAGES.iter().map(|(_, shader, _)| *shader))
}

/// The optional stages the backend holds by name, because the batch loop depends on them (the
/// periodic cell's shear schedule and slip; pore flow's sub-steps and network rebuilds), and
/// the heat ledger, which is booked inside the stages that dissipate.
const HELD_BY_NAME: [Stage; 3] = [Stage::PoreFlow, Stage::Periodic, Stage::HeatLedger];

/// The walls whose loads a step of `plan` reads (bit w for wall w: the servo walls), when
/// fewer than all (a scene has at most `walls::MAX_WALLS`): the steps but a batch's last leave
/// the load partials of those alone.
fn quiet_loads(plan: &StepPlan) -> Option<u32> {
    let all = (1u32 << plan.walls) - 1;
    (plan.servo_mask != all).then_some(plan.servo_mask)
}

/// Steps one batch may hold before the host looks at the drift again.
const MAX_BATCH: u64 = 64;

/// Models up to this many particles stay on the device between runs ([`Resident`]). Above
/// it a run's steps dwarf an upload, and the copy of the model kept to compare against
/// would double the host's memory.
const RESIDENT_MAX_PARTICLES: usize = 200_000;

/// Label of the compute pass that runs a batch of steps (walls → contact_forces →
/// wall_forces → integrate, each step; then the neighbours stage's drift measure and, at a
/// guard step, the guard).
const STEP_BATCH: &str = "step_batch";

/// The plan's pipelines, one field per stage (the wall stages only with walls).
struct Pipelines {
    /// The neighbours stage: the drift measure, and the rows built on the device.
    drift: Pipeline,
    rows: rows::Pipelines,
    contact_forces: Pipeline,
    walls: Option<WallPipelines>,
    /// Only when the plan has pore flow (the stages of `DEVICE_STAGES` build theirs at upload).
    pore_flow: Option<pore_flow::Pipelines>,
    integrate: Pipeline,
    guard: Pipeline,
}

/// The pipelines of the walls and wall_forces stages.
struct WallPipelines {
    /// Last step's loads summed (only with a servo wall, which steers by them), then the
    /// walls moved.
    advance: Pipeline,
    /// `advance` sums the loads first.
    advance_sums: bool,
    /// The wall pass; with integration in it when `integrates`.
    forces: Pipeline,
    /// The same pass leaving the load partials of the servo walls alone (none without one), the
    /// only loads a step reads: for all steps of a batch but its last (a download sums the
    /// last's). None when every wall is a servo.
    quiet: Option<Pipeline>,
    /// No force stage runs between the wall pass and integration, so the pass integrates too.
    integrates: bool,
    /// The loads summed alone (before a download).
    sum_loads: Pipeline,
    /// The partials folded 64 at a time before either sum (scenes of over 256 workgroups).
    fold: Pipeline,
}

/// Kernels bound to one upload; those that read per-entry lanes, one per slab.
struct Kernels {
    drift: Kernel,
    rows: rows::Kernels,
    contact_forces: Vec<Kernel>,
    walls: Option<WallKernels>,
    integrate: Kernel,
    guard: Vec<Kernel>,
}

/// [`WallPipelines`] bound to one upload; the wall forces one per slab.
struct WallKernels {
    advance: Kernel,
    /// [`WallPipelines::advance_sums`].
    advance_sums: bool,
    forces: Vec<Kernel>,
    /// [`WallPipelines::quiet`]'s kernels.
    quiet: Option<Vec<Kernel>>,
    /// The wall pass integrates too (`forces` are the integrating pipeline's): the integrate
    /// stage has no pass of its own.
    integrates: bool,
    sum_loads: Kernel,
    fold: Option<Kernel>,
}

impl Kernels {
    /// The name of `stage`'s pass: the wall pass that integrates says so.
    fn label(&self, stage: Stage) -> &'static str {
        match (stage, &self.walls) {
            (Stage::WallForces, Some(w)) if w.integrates => "wall_forces + integrate",
            _ => stage.name(),
        }
    }
}

impl WallKernels {
    /// The walls stage's kernels: the partials folded (when they are), then `sum`.
    fn summing<'k>(&'k self, sum: &'k Kernel) -> Vec<&'k Kernel> {
        self.fold.iter().chain([sum]).collect()
    }
}

/// The model on the device, from an upload to the next download.
struct Session {
    host: HostLanes,
    lanes: DeviceLanes,
    kernels: Kernels,
    /// The stages of `DEVICE_STAGES` the plan runs, in its order.
    stages: DeviceStages,
    /// Steps run since the upload.
    steps: u64,
    /// The model's step at the upload (a field stage runs after every `every`-th).
    step0: u64,
    /// The pore_flow stage's network, fluid and kernels, when the plan has it.
    pores: Option<pore_flow::PoreSession>,
    /// The periodic cell's crossings, when the plan has one.
    periodic: Option<periodic::Session>,
}

impl Session {
    /// Whether the session may continue after a download: every lane it holds is then either
    /// the model's (downloaded whole) or restarted by [`GpuBackend::rewind`]. The pore network
    /// and the stages that say so (conduction) keep sums since the upload that a download adds
    /// to the model (the network's geometry, the heat fed), so they upload afresh.
    fn can_continue(&self) -> bool {
        self.pores.is_none() && !self.stages.keep_sums()
    }
}

/// A session kept on the device after a run synced the model, and the model as that sync
/// left it (as a checkpoint encodes it: every lane, section and setting). The next run
/// continues on the device when the model still encodes to the same bytes; any change a
/// script made, however small, means a fresh upload. Small scenes run as many short runs
/// (a tolerance balance checks every 100 steps, a servo loop reads the platen between runs),
/// and an upload rebuilds every buffer and bind group: on a hardware GPU that, not the
/// steps, was the time of such a run.
struct Resident {
    session: Session,
    model: Vec<u8>,
}

/// How the rows of a backend's runs were built, for tests and benchmarks: a rebuild on the
/// device costs no transfer of the model, one through the host costs a download and an upload.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RowStats {
    /// Models put on the device (each run's first, plus one after each host build or sample).
    pub uploads: u64,
    pub device_builds: u64,
    /// Rebuilds that went through the host, and why the last one did.
    pub host_builds: u64,
    pub host_reason: Option<String>,
    /// Slabs the per-entry lanes of the last upload were split into.
    pub slabs: usize,
    /// Runs that continued on the device without an upload: the model was unchanged since
    /// the last run synced it ([`Resident`]).
    pub continued: u64,
}

/// A plan's pipelines on one device.
pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    pub plan: StepPlan,
    pipelines: Pipelines,
    /// The plan's pipeline constants (the laws, the heat ledger's slots), for the stages built
    /// at upload.
    constants: Vec<(&'static str, f64)>,
    /// c_i/m_i of the viscous damping (empty when off).
    damping_rate: Vec<f64>,
    /// Bytes of the device buffers of the last run.
    device_bytes: u64,
    /// The heat ledger's slots.
    ledger: heat_ledger::Layout,
    /// The first error the device reported outside a call (wgpu's uncaptured errors).
    errors: Arc<Mutex<Option<String>>>,
    /// A storage binding limit below the device's (tests of the split into slabs).
    binding_limit: Option<u64>,
    rows: RowStats,
    /// The model on the device between a run's first chunk and the next sync.
    session: Option<Session>,
    /// The session kept after the last sync, for the next run to continue when it can.
    resident: Option<Resident>,
    /// Steps the next batch may hold, from the drift of the last (1 after an upload or a
    /// row build).
    batch: u64,
    /// The last guard found a contact too stiff for dt (its lowest particle id).
    stiff: Option<u32>,
}

impl GpuBackend {
    /// Builds the pipelines the model's plan needs.
    pub fn prepare(ctx: Arc<GpuContext>, m: &Model) -> Result<Self> {
        let plan = StepPlan::build(m);
        let damping = plan.damping_coefficients(m);
        Self::with_plan(ctx, m, plan, &damping)
    }

    /// Builds the pipelines `plan` needs; `damping` holds the particles' viscous damping
    /// coefficients ([`StepPlan::damping_coefficients`]).
    pub fn with_plan(ctx: Arc<GpuContext>, m: &Model, plan: StepPlan, damping: &[f64]) -> Result<Self> {
        let errors = Arc::new(Mutex::new(None::<String>));
        let sink = errors.clone();
        ctx.device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            if slot.is_none() {
                // Display carries the chain of causes (Debug would add the whole shader).
                *slot = Some(e.to_string());
            }
        }));
        let device: &GpuContext = &ctx; // the pipelines are cached on the context
        let ledger = heat_ledger::Layout::for_plan(&plan);
        let mut constants = shaders::constants(&plan);
        constants.extend(ledger.constants());
        let pipelines = Pipelines {
            drift: neighbours::pipeline(device, &constants),
            rows: rows::pipelines(device, &constants),
            contact_forces: contact_forces::pipeline(device, &constants),
            walls: (plan.walls > 0).then(|| WallPipelines {
                advance: walls::pipeline(device, &constants, plan.servo_mask != 0),
                advance_sums: plan.servo_mask != 0,
                forces: wall_forces::pipeline(device, &constants, !plan.has_force_stage(), None),
                quiet: quiet_loads(&plan)
                    .map(|mask| wall_forces::pipeline(device, &constants, !plan.has_force_stage(), Some(mask))),
                integrates: !plan.has_force_stage(),
                sum_loads: walls::sum_pipeline(device, &constants),
                fold: walls::fold_pipeline(device, &constants),
            }),
            pore_flow: plan.pore_flow.map(|f| pore_flow::pipelines(device, &constants, f.thermal)),
            integrate: integrate::pipeline(device, &constants),
            guard: guard::pipeline(device, &constants),
        };
        // The kernels scale velocities, so they take c_i/m_i.
        let damping_rate = damping.iter().zip(&m.particles.mass).map(|(c, mass)| c / mass).collect();
        let backend = GpuBackend {
            ctx,
            plan,
            pipelines,
            constants,
            damping_rate,
            device_bytes: 0,
            errors,
            ledger,
            binding_limit: None,
            rows: RowStats::default(),
            session: None,
            resident: None,
            batch: 1,
            stiff: None,
        };
        backend.check_device()?;
        Ok(backend)
    }

    /// The adapter, in words.
    pub fn device_name(&self) -> String {
        self.ctx.describe()
    }

    /// Bytes of device memory the last run used.
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }

    /// How the rows were built so far.
    pub fn row_stats(&self) -> &RowStats {
        &self.rows
    }

    /// Lets one storage binding span at most `bytes` (if below the device's limit), so a
    /// small model splits into slabs as a large one would on a real device. Results do not
    /// change: a split run is bitwise the unsplit one.
    pub fn limit_bindings(&mut self, bytes: u64) {
        self.binding_limit = Some(bytes);
    }

    /// Runs integration in a pass of its own even where the wall pass could do it: the two
    /// ways give the same bits (`engine/tests/gpu_parity.rs`). Takes effect at the next upload.
    pub fn separate_passes(&mut self) {
        let mut constants = shaders::constants(&self.plan);
        constants.extend(self.ledger.constants());
        let quiet = quiet_loads(&self.plan);
        if let Some(w) = self.pipelines.walls.as_mut().filter(|w| w.integrates) {
            w.forces = wall_forces::pipeline(&self.ctx, &constants, false, None);
            w.quiet = quiet.map(|mask| wall_forces::pipeline(&self.ctx, &constants, false, Some(mask)));
            w.integrates = false;
        }
    }

    /// Sums every wall's load at every step, in the wall pass and in the walls pass that
    /// follows it, where a plan sums a servo wall's alone (none without one) but at a batch's
    /// last step: both give the same bits
    /// (`engine/tests/gpu_parity.rs`). Takes effect at the next upload.
    pub fn sum_loads_every_step(&mut self) {
        let mut constants = shaders::constants(&self.plan);
        constants.extend(self.ledger.constants());
        if let Some(w) = self.pipelines.walls.as_mut() {
            w.quiet = None;
            w.advance = walls::pipeline(&self.ctx, &constants, true);
            w.advance_sums = true;
        }
    }

    fn limits(&self) -> memory::Limits {
        let mut l = memory::Limits::of(&self.ctx.limits);
        if let Some(b) = self.binding_limit {
            l.binding = l.binding.min(b);
        }
        l
    }

    fn check_device(&self) -> Result<()> {
        match self.errors.lock().unwrap_or_else(|p| p.into_inner()).take() {
            Some(e) => Err(GpuError::Device(e).into()),
            None => Ok(()),
        }
    }

    /// Brings the model to what an upload needs: rows that cover it, the core's lanes the plan
    /// reads (a stage of `DEVICE_STAGES` fits its own at its upload).
    fn ready(&self, m: &mut Model) {
        if is_stale(&m.contacts, &m.particles.pos, m.effects.periodic.cell.as_ref()) {
            rebuild(m);
        }
        if self.plan.rotation && m.particles.rotation.is_none() {
            m.particles.enable_rotation();
        }
    }

    /// The session a run starts from: the one the last sync kept, when the model has not
    /// changed since ([`Resident`]), else a fresh upload.
    fn open(&mut self, m: &mut Model) -> Result<Session> {
        if let Some(r) = self.resident.take() {
            self.ready(m);
            if crate::checkpoint::encode(m, &[]) == r.model {
                self.rows.continued += 1;
                return Ok(r.session);
            }
        }
        self.batch = 1;
        self.upload(m)
    }

    /// Puts the model on the device (rows rebuilt first if they do not cover it).
    fn upload(&mut self, m: &mut Model) -> Result<Session> {
        self.ready(m);
        if m.wall_contacts.len() != m.len() * m.walls.len() {
            return Err(Error::InvalidScene("wall contact states do not match the walls: rebuild the model".into()));
        }
        let n = m.len();
        let c = &m.contacts;
        let longest = (0..n).map(|i| c.row(i).len()).max().unwrap_or(0);
        // Each bond, MatDEM's or parallel, may break once: room for an event each.
        let bonds = c.state.iter().filter(|s| s.bonded).count() / 2 + m.parallel_bonds.intact();
        let scene = memory::Scene {
            particles: n,
            longest_row: longest,
            walls: m.walls.len(),
            rotation: self.plan.rotation,
            bonds,
            dashpot: self.plan.dashpot,
            heat_lanes: self.ledger.lanes(),
            rolling: self.plan.rolling.is_some_and(|r| r.model == RollingModel::Epsd),
            pore_corners: match (&self.plan.pore_flow, &m.pores) {
                (Some(_), Some(f)) => 4 * f.network.tri.tets.len(),
                _ => 0,
            },
            pore_heat: self.plan.pore_flow.is_some_and(|p| p.thermal),
            applied_loads: self.plan.applied_loads.map_or(0, |a| 1 + usize::from(a.torques)),
        };
        let limits = self.limits();
        let layout = memory::MemoryPlan::new(scene, limits)?;
        let host = HostLanes::from_model(m, &self.plan, &self.damping_rate, layout.cap, self.ledger.lanes());
        let wall_groups = wall_forces::partial_groups(n);
        let r_max = m.particles.radius.iter().copied().fold(0.0, f64::max);
        let skin = m.contacts.skin;
        let image = m.effects.periodic.cell.map(|c| c.image()).unwrap_or_default();
        let v4 = |v: &Vec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
        let params = Params {
            n: n as u32,
            nw: m.walls.len() as u32,
            nmat: self.plan.materials as u32,
            max_events: layout.max_events as u32,
            dt: m.clock.dt as f32,
            local_damping: m.settings.local_damping as f32,
            max_overlap_ratio: m.settings.max_overlap_ratio as f32,
            wall_groups: wall_groups as u32,
            gravity: [m.settings.gravity.x as f32, m.settings.gravity.y as f32, m.settings.gravity.z as f32, 0.0],
            cap: layout.cap as u32,
            buckets: memory::buckets(n) as u32,
            skin: skin as f32,
            // The longest reach, padded so f32 round-off never puts a neighbour two cells away.
            cell: ((2.0 * r_max + skin) * 1.001) as f32,
            one: 1.0,
            wall_blocks: walls::blocks(wall_groups) as u32,
            pad: [0.0; 2],
            period: v4(&image.len),
            period_inv: v4(&image.inv),
            period_lo: v4(&Vec3::from_fn(|k, _| m.effects.periodic.cell.and_then(|c| c.axes[k]).map_or(0.0, |a| a[0]))),
            // Written by the periodic stage's session under Lees–Edwards shear.
            shear: [0.0; 4],
        };
        let limit = limits.binding.min(limits.buffer);
        let lanes = DeviceLanes::upload(&self.ctx, &host, params, &layout, limit)?;
        let mut stages = DeviceStages::default();
        for &(stage, _, upload) in DEVICE_STAGES {
            let u = UploadContext {
                ctx: &self.ctx,
                constants: &self.constants,
                plan: &self.plan,
                lanes: &lanes,
                limit,
                earlier: &stages,
            };
            if let Some(work) = upload(m, &u)? {
                stages.push(stage, work);
            }
        }
        // An optional stage the plan runs has its work here or is held by name.
        let missing = |s: &Stage| !HELD_BY_NAME.contains(s) && stages.get(*s).is_none();
        if let Some(s) =
            REGISTRY.iter().filter(|e| e.effect).map(|e| e.stage).filter(|s| self.plan.has(*s)).find(missing)
        {
            return Err(GpuError::Device(format!("the stage `{s}` has no GPU work (DEVICE_STAGES)")).into());
        }
        let device = &self.ctx.device;
        let p = &self.pipelines;
        let pores = match &p.pore_flow {
            Some(pipelines) => {
                let thermal = stages.find::<conduction::Field>(Stage::Conduction).map(conduction::Field::lanes);
                Some(pore_flow::PoreSession::upload(&self.ctx, m, &host, &lanes, pipelines, thermal, limit)?)
            }
            None => None,
        };
        let kernels = Kernels {
            drift: neighbours::kernel(device, &p.drift, &lanes)?,
            rows: rows::kernels(device, &p.rows, &lanes)?,
            contact_forces: contact_forces::kernels(device, &p.contact_forces, &lanes)?,
            walls: match &p.walls {
                Some(w) => Some(WallKernels {
                    advance: walls::kernel(device, &w.advance, &lanes)?,
                    advance_sums: w.advance_sums,
                    forces: wall_forces::kernels(device, &w.forces, &lanes)?,
                    quiet: w.quiet.as_ref().map(|q| wall_forces::kernels(device, q, &lanes)).transpose()?,
                    integrates: w.integrates,
                    sum_loads: walls::kernel(device, &w.sum_loads, &lanes)?,
                    fold: walls::fold_kernel(device, &w.fold, &lanes, walls::blocks(wall_groups))?,
                }),
                None => None,
            },
            integrate: integrate::kernel(device, &p.integrate, &lanes)?,
            guard: guard::kernels(device, &p.guard, &lanes)?,
        };
        let cell = match self.plan.periodic {
            Some(_) => Some(periodic::Session::upload(&self.ctx, &self.constants, m, &lanes, MAX_BATCH)?),
            None => None,
        };
        self.device_bytes =
            lanes.bytes + stages.bytes() + cell.as_ref().map_or(0, |c| c.bytes) + pores.as_ref().map_or(0, |f| f.bytes);
        self.rows.uploads += 1;
        self.rows.slabs = lanes.slabs.len();
        self.check_device()?;
        Ok(Session { host, lanes, kernels, stages, steps: 0, step0: m.clock.step, pores, periodic: cell })
    }

    /// Rebuilds the rows on the device: `Ok(Err(why))` when they did not fit their slots (the
    /// rows are then untouched and the host must build them).
    fn build_rows(&mut self, s: &mut Session) -> Result<std::result::Result<(), String>> {
        let ctx = &self.ctx;
        ctx.queue.write_buffer(&s.lanes.counters, (C_LONGEST * 4) as u64, bytemuck::cast_slice(&[0u32; 2]));
        debug_assert_eq!(C_CROWDED, C_LONGEST + 1);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        s.kernels.rows.encode(&mut enc, &s.lanes);
        ctx.submit(enc);
        let counters = read::<u32>(ctx, &s.lanes.counters, COUNTERS)?;
        self.check_device()?;
        let verdict = rows::verdict(&counters, s.lanes.plan.cap);
        if verdict.is_ok() {
            self.rows.device_builds += 1;
            if let Some(c) = s.periodic.as_mut() {
                c.rows_built();
            }
        }
        Ok(verdict)
    }

    /// Uploads the model, rebuilds its rows once on the device, and brings them back (for
    /// tests that compare them with the host's build). `Err(why)` inside when they did not fit.
    pub fn build_rows_once(&mut self, m: &mut Model) -> Result<std::result::Result<(), String>> {
        let mut session = self.upload(m)?;
        let verdict = self.build_rows(&mut session)?;
        self.download(m, &mut session)?;
        Ok(verdict)
    }

    /// Readies the counters a batch reports: the drift and speed maxima, the guard's minima
    /// (and its stiffness finding when `guard`), the pore stage's.
    fn reset_batch_counters(&self, s: &Session, guard: bool) {
        let ctx = &self.ctx;
        let mut reset = [0u32; C_GUARD + 4 - C_DRIFT];
        reset[C_GUARD - C_DRIFT..].fill(u32::MAX);
        ctx.queue.write_buffer(&s.lanes.counters, (C_DRIFT * 4) as u64, bytemuck::cast_slice(&reset));
        if guard {
            ctx.queue.write_buffer(&s.lanes.counters, (C_STIFF * 4) as u64, bytemuck::cast_slice(&[u32::MAX]));
        }
        if s.pores.is_some() {
            debug_assert_eq!((C_PORE_DRIFT, C_PORE_EXCHANGE), (C_PORE_STEP + 1, C_PORE_STEP + 2));
            let reset = [u32::MAX, 0, u32::MAX];
            ctx.queue.write_buffer(&s.lanes.counters, (C_PORE_STEP * 4) as u64, bytemuck::cast_slice(&reset));
        }
    }

    /// One step's stages in the order the device runs them, `t` steps into the batch: the
    /// plan's stages in step order (walls: last step's loads summed, then moved; contact forces;
    /// wall forces; the force stages; integration; the field stages due after this step).
    /// `last`: the batch's last step, whose wall loads a download may read.
    fn step_stages<'s>(&'s self, s: &'s Session, t: u64, last: bool) -> Vec<(Stage, StageWork<'s>)> {
        let kr = &s.kernels;
        let step = s.step0 + s.steps + t;
        let work = |stage: Stage| -> Option<StageWork<'s>> {
            Some(match stage {
                // Walls that never move need no pass a step: their loads are summed when a
                // download reads them (`download`), and a fixed wall's velocity is zero from
                // the upload.
                Stage::Walls if self.plan.fixed_walls_only() => return None,
                Stage::Walls => {
                    let w = kr.walls.as_ref()?;
                    // Without a servo the walls move alone: no fold, no sum.
                    StageWork::Kernels(if w.advance_sums { w.summing(&w.advance) } else { vec![&w.advance] })
                }
                Stage::ContactForces => StageWork::Kernels(kr.contact_forces.iter().collect()),
                Stage::WallForces => {
                    let w = kr.walls.as_ref()?;
                    // A step reads only the servo walls' loads; the others are read by a
                    // download, after a batch's last step (the walls pass sums their stale
                    // partials too: nothing reads those sums).
                    let kernels = match &w.quiet {
                        Some(quiet) if !last => quiet,
                        _ => &w.forces,
                    };
                    StageWork::Kernels(kernels.iter().collect())
                }
                Stage::PoreFlow => StageWork::Pores(s.pores.as_ref()?),
                Stage::Integrate if kr.walls.as_ref().is_some_and(|w| w.integrates) => return None,
                Stage::Integrate => StageWork::Kernels(vec![&kr.integrate]),
                Stage::Periodic => StageWork::Kernels(vec![s.periodic.as_ref()?.kernel()?]),
                // The rows' drift and the guard end a batch (`batch_tail`); the heat ledger is
                // booked inside the stages that dissipate.
                Stage::Neighbours | Stage::HeatLedger | Stage::Guard => return None,
                // A stage of `DEVICE_STAGES` (the upload refused a plan whose stage has no
                // work), unless it is not due after this step (a field stage).
                other => match s.stages.get(other)?.kernels(step) {
                    none if none.is_empty() => return None,
                    kernels => StageWork::Kernels(kernels),
                },
            })
        };
        self.plan.stages().into_iter().filter_map(|stage| Some((stage, work(stage)?))).collect()
    }

    /// What ends a batch: the neighbours stage's drift measure (the pore network's too) and,
    /// when `guard`, the guard's checks.
    fn batch_tail<'s>(&'s self, s: &'s Session, guard: bool) -> Vec<(Stage, StageWork<'s>)> {
        let kr = &s.kernels;
        let mut out = vec![(Stage::Neighbours, StageWork::Kernels(vec![&kr.drift]))];
        if let Some(f) = &s.pores {
            out.push((Stage::PoreFlow, StageWork::PoreDrift(f)));
        }
        if guard {
            out.push((Stage::Guard, StageWork::Kernels(kr.guard.iter().collect())));
        }
        out
    }

    /// Encodes `k` steps, the drift measure and (when `guard`) the guard's checks, submits
    /// them and reads the counters back.
    fn step_batch(&self, s: &Session, k: u64, guard: bool) -> Result<Vec<u32>> {
        let ctx = &self.ctx;
        self.reset_batch_counters(s, guard);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        // Under Lees–Edwards shear each step reads its own offsets, copied into the params
        // between passes: one pass a step (and one for the tail); else one pass for all.
        let sheared = match &s.periodic {
            Some(c) if c.schedule(ctx, k)? => Some(c),
            _ => None,
        };
        let mut t = 0;
        while t <= k {
            let end = if sheared.is_some() { t + 1 } else { k + 1 };
            if let Some(c) = sheared {
                c.copy_entry(&mut enc, &s.lanes.params, t);
            }
            let mut pass = enc
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(STEP_BATCH), timestamp_writes: None });
            for u in t..end.min(k) {
                for (stage, work) in self.step_stages(s, u, u + 1 == k) {
                    work.encode(&mut pass, stage);
                }
            }
            if end > k {
                for (stage, work) in self.batch_tail(s, guard) {
                    work.encode(&mut pass, stage);
                }
            }
            drop(pass);
            t = end;
        }
        ctx.submit(enc);
        let counters = read::<u32>(ctx, &s.lanes.counters, COUNTERS)?;
        self.check_device()?;
        Ok(counters)
    }

    /// Brings the device's state into the model, appends the bonds that broke (in step and
    /// particle order, as the CPU backend records them) and advances the clock. The session
    /// may continue only after [`rewind`](Self::rewind).
    fn download(&self, m: &mut Model, s: &mut Session) -> Result<()> {
        if let (Some(w), true) = (&s.kernels.walls, s.steps > 0) {
            // The walls hold the loads of the step before the last: sum the last step's.
            let mut enc = self.ctx.device.create_command_encoder(&Default::default());
            let label = Some("walls: sum_wall_loads");
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label, timestamp_writes: None });
            for k in w.summing(&w.sum_loads) {
                k.dispatch(&mut pass);
            }
            drop(pass);
            self.ctx.submit(enc);
        }
        download(&self.ctx, &s.lanes, &mut s.host, m, self.plan.rotation)?;
        for (_, work) in s.stages.iter() {
            work.download(&self.ctx, &s.lanes, m, &s.stages)?;
        }
        if let Some(f) = &s.pores {
            f.download(&self.ctx, m)?;
        }
        if let Some(c) = &s.periodic {
            c.download(&self.ctx, m)?;
        }
        self.ledger.fold(&self.ctx, &s.lanes, m)?;
        let counters = read::<u32>(&self.ctx, &s.lanes.counters, COUNTERS)?;
        let count = counters[C_EVENTS] as usize;
        if count > s.lanes.plan.max_events {
            return Err(GpuError::Device(format!(
                "{count} bonds broke in one run, more than the {} the event lane holds; run fewer steps at a time",
                s.lanes.plan.max_events
            ))
            .into());
        }
        let mut events: Vec<[u32; 4]> = read(&self.ctx, &s.lanes.events, count)?;
        events.sort_unstable();
        let (step0, time0, dt) = (m.clock.step, m.clock.time, m.clock.dt);
        for [step, i, j, kind] in events {
            let kind = if kind == 1 { BreakKind::Tension } else { BreakKind::Shear };
            let step = u64::from(step);
            m.breakages.push(Breakage { step: step0 + step, time: time0 + step as f64 * dt, i, j, kind });
        }
        for _ in 0..s.steps {
            m.clock.step += 1;
            m.clock.time += dt;
        }
        // The rows came back as the device last built them; the host's wall mask goes with them.
        rebuild_wall_mask(m);
        self.check_device()
    }

    /// Reads a batch's findings: stops the run when the guard (if it ran) or the maxima found
    /// the state unstable, else returns the largest drift since the rows' build and the
    /// largest speed.
    fn check_batch(&self, m: &mut Model, s: &mut Session, counters: &[u32], guard: bool) -> Result<(f64, f64)> {
        let failed = (0..4).find(|&k| counters[C_GUARD + k] != u32::MAX).filter(|_| guard);
        if let Some(slot) = failed {
            let particle = counters[C_GUARD + slot] as usize;
            self.download(m, s)?;
            // The CPU guard words it (and finds the same particle, unless f32 and f64
            // disagree at the threshold: then the device's finding stands).
            crate::guard::check_state(m)?;
            return Err(crate::guard::unstable(m, particle, guard::FAILURES[slot].to_string()));
        }
        let drift = f64::from(f32::from_bits(counters[C_DRIFT])).sqrt();
        let speed = f64::from(f32::from_bits(counters[C_SPEED])).sqrt();
        if !(drift.is_finite() && speed.is_finite()) {
            self.download(m, s)?;
            crate::guard::check_state(m)?;
            return Err(crate::guard::unstable(m, 0, guard::FAILURES[0].to_string()));
        }
        Ok((drift, speed))
    }

    /// Sizes the next batch by the drift rule (at most `limit` steps), or rebuilds the rows
    /// now: on the device, or through the host when they outgrow their slots.
    fn keep_rows_current(&mut self, m: &mut Model, s: &mut Session, drift: f64, speed: f64, limit: u64) -> Result<()> {
        let skin = m.contacts.skin;
        let next = match s.periodic.as_ref().and_then(periodic::Session::sliding) {
            Some((slip, slide)) => steps_until_rebuild_sheared(drift, speed, skin, m.clock.dt, MAX_BATCH, slip, slide),
            None => steps_until_rebuild(drift, speed, skin, m.clock.dt, MAX_BATCH),
        };
        match next {
            Some(k) => self.batch = k.min(limit),
            None => {
                if let Err(why) = self.build_rows(s)? {
                    // The rows did not fit: the host builds them and widens the slots.
                    self.download(m, s)?;
                    rebuild(m);
                    self.rows.host_builds += 1;
                    self.rows.host_reason = Some(why);
                    *s = self.upload(m)?;
                }
                self.batch = 1;
            }
        }
        Ok(())
    }

    /// Restarts what a session counts since its upload, after a download has added it to the
    /// model (the step counter and breakage events, the heat ledger's sums), so that the
    /// session continues as a fresh upload of the downloaded model would start.
    fn rewind(&self, m: &Model, s: &mut Session) {
        let q = &self.ctx.queue;
        q.write_buffer(&s.lanes.counters, 0, bytemuck::cast_slice(&buffers::initial_counters()));
        if self.ledger.lanes() > 0 {
            let mut enc = self.ctx.device.create_command_encoder(&Default::default());
            enc.clear_buffer(&s.lanes.heat, 0, None);
            q.submit([enc.finish()]);
        }
        s.steps = 0;
        s.step0 = m.clock.step;
    }

    /// Syncs the model and keeps the session on the device for the next run, when it can
    /// continue and the model is small enough to compare ([`Resident`]).
    fn sync_session(&mut self, m: &mut Model, mut s: Session) -> Result<()> {
        self.download(m, &mut s)?;
        if s.can_continue() && s.lanes.n <= RESIDENT_MAX_PARTICLES {
            self.rewind(m, &mut s);
            self.resident = Some(Resident { session: s, model: crate::checkpoint::encode(m, &[]) });
        }
        Ok(())
    }
}

impl Backend for GpuBackend {
    /// Steps the chunk in batches of command buffers, each as long as the drift allows
    /// (at most `MAX_BATCH`, 64) and none across a sampled step; the last batch runs the guard's
    /// checks. After each batch the host reads the largest drift and speed, and the rows are
    /// rebuilt (on the device, or through the host when they outgrow their slots) when the
    /// drift rule says so. A sampled step brings the model back to the host, measures it
    /// there and puts it back.
    fn run_chunk(
        &mut self,
        m: &mut Model,
        steps: u64,
        sampling: Sampling,
        sample: &mut dyn FnMut(EnergySample),
    ) -> Result<()> {
        // Taken out for the chunk: an error drops the device's state, as it stands.
        let mut session = match self.session.take() {
            Some(s) => s,
            None => self.open(m)?,
        };
        let mut done = 0;
        while done < steps {
            if sampling.at(done) {
                self.download(m, &mut session)?;
                let mut energies = potential_energies(m, &self.plan);
                energies.kinetic = kinetic_energy(m);
                sample(EnergySample { step: m.clock.step, time: m.clock.time, energies });
                // Measuring changed nothing: the session goes on where it can.
                if session.can_continue() {
                    self.rewind(m, &mut session);
                } else {
                    session = self.upload(m)?;
                }
            }
            let k = self.batch.min(sampling.gap(done)).min(steps - done);
            let guard_now = done + k == steps;
            let counters = self.step_batch(&session, k, guard_now)?;
            done += k;
            session.steps += k;
            if let Some(c) = session.periodic.as_mut() {
                c.stepped(k);
            }
            if let Some(f) = session.pores.as_mut() {
                f.stepped = true;
            }
            if guard_now {
                self.stiff = (counters[C_STIFF] != u32::MAX).then_some(counters[C_STIFF]);
            }
            let (drift, speed) = self.check_batch(m, &mut session, &counters, guard_now)?;
            // The pore network: the next batch's sub-steps from this batch's smallest stable flow
            // step; a rebuild (through the host) when the drift may pass the threshold next step.
            let mut pore_batch = MAX_BATCH;
            if let Some(f) = session.pores.as_mut() {
                let crit = match counters[C_PORE_STEP] {
                    u32::MAX => f64::INFINITY,
                    bits => f64::from(f32::from_bits(bits)),
                };
                let need = crate::effects::pore_flow::flow::substeps_for(m.clock.dt, crit);
                // The fluid–grain heat exchange, likewise (its stable step C/ΣG of either side).
                let exchange = f.exchange_substeps().map(|now| {
                    let crit = match counters[C_PORE_EXCHANGE] {
                        u32::MAX => f64::INFINITY,
                        bits => f64::from(f32::from_bits(bits)),
                    };
                    (now, crate::effects::pore_flow::flow::substeps_for(m.clock.dt, crit))
                });
                let exchange_over = exchange.is_some_and(|(_, x)| x > f64::from(f.max_substeps));
                let pore_drift = f64::from(f32::from_bits(counters[C_PORE_DRIFT])).sqrt();
                let rebuild_in = steps_until_rebuild(pore_drift, speed, 2.0 * f.drift_limit, m.clock.dt, MAX_BATCH);
                if need > f64::from(f.max_substeps) || exchange_over || rebuild_in.is_none() {
                    // Through the host: its f64 check words the guard's error (or finds the
                    // flow stable after all), or it rebuilds the network.
                    self.download(m, &mut session)?;
                    if rebuild_in.is_none() {
                        if let Some(mut p) = m.pores.take() {
                            let r = p.rebuild(m);
                            m.pores = Some(p);
                            r?;
                        }
                    }
                    session = self.upload(m)?;
                    self.batch = 1;
                    continue;
                }
                // The stable step fell within the batch: look again after each step.
                if need as u32 > f.substeps {
                    pore_batch = 1;
                }
                f.set_substeps(&self.ctx, need as u32, m.clock.dt);
                if let Some((now, x)) = exchange {
                    if x as u32 > now {
                        pore_batch = 1;
                    }
                    f.set_exchange_substeps(&self.ctx, x as u32, m.clock.dt);
                }
                pore_batch = pore_batch.min(rebuild_in.unwrap_or(1));
            }
            self.keep_rows_current(m, &mut session, drift, speed, pore_batch)?;
        }
        self.session = Some(session);
        Ok(())
    }

    /// The guard kernel flagged a contact too stiff for dt in the chunk's last batch: the
    /// state comes back and the host finds the contact in f64 (should f32 and f64 disagree
    /// at the threshold, the stiffest contact of the model stands for the device's finding).
    fn too_stiff(&mut self, m: &mut Model) -> Result<Option<StiffContact>> {
        if self.stiff.take().is_none() {
            return Ok(None);
        }
        self.sync(m)?;
        Ok(crate::guard::too_stiff(m, &self.plan).or_else(|| crate::guard::stiffest_contact(m, &self.plan)))
    }

    fn sync(&mut self, m: &mut Model) -> Result<()> {
        match self.session.take() {
            Some(s) => self.sync_session(m, s),
            None => Ok(()),
        }
    }

    fn bytes(&self) -> usize {
        self.device_bytes as usize
    }
}

/// What one stage of a step dispatches.
enum StageWork<'s> {
    Kernels(Vec<&'s Kernel>),
    Pores(&'s pore_flow::PoreSession),
    PoreDrift(&'s pore_flow::PoreSession),
}

impl StageWork<'_> {
    /// Dispatches the stage's kernels inside a debug group named for the stage, so that a
    /// capture (RenderDoc, Nsight) shows a step as the plan's named stages.
    fn encode(&self, pass: &mut wgpu::ComputePass<'_>, stage: Stage) {
        match self {
            StageWork::Kernels(kernels) => {
                pass.push_debug_group(stage.name());
                for k in kernels {
                    k.dispatch(pass);
                }
                pass.pop_debug_group();
            }
            StageWork::Pores(f) => f.dispatch(pass),
            StageWork::PoreDrift(f) => f.dispatch_drift(pass),
        }
    }

    /// Dispatches, and the bytes their kernels bind (`None` for the pore network's stage,
    /// which `bench --profile` does not measure).
    fn cost(&self) -> Option<(u64, u64)> {
        match self {
            StageWork::Kernels(kernels) => Some((kernels.len() as u64, kernels.iter().map(|k| k.bytes).sum())),
            StageWork::Pores(_) | StageWork::PoreDrift(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stage added to the registry without its device work fails here, before any device
    /// would refuse its plan at upload.
    #[test]
    fn every_optional_stage_has_its_device_work_listed_once_or_is_held_by_name() {
        for e in REGISTRY.iter().filter(|e| e.effect) {
            let listed = DEVICE_STAGES.iter().filter(|(s, ..)| *s == e.stage).count();
            let held = usize::from(HELD_BY_NAME.contains(&e.stage));
            assert_eq!(listed + held, 1, "{}: in DEVICE_STAGES {listed} time(s), held by name {held}", e.name);
        }
        for (stage, shader, _) in DEVICE_STAGES {
            assert_eq!(shader.name, stage.name(), "DEVICE_STAGES: a stage's row holds its own WGSL");
        }
        let order: Vec<usize> =
            DEVICE_STAGES.iter().map(|(s, ..)| Stage::ALL.iter().position(|a| a == s).unwrap()).collect();
        assert!(order.is_sorted(), "DEVICE_STAGES is in step order");
    }
}
