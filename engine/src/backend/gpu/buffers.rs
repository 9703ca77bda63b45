//! The device's copy of a model: one buffer per lane, in the layout common.wgsl declares,
//! and the conversions between the model's f64 lanes and the device's f32 ones. Per-entry
//! lanes (rows, pair and wall contact states) are split into slabs ([`super::memory`]).
//!
//! Positions go up as an f32 origin (the f64 position rounded) plus the f32 remainder, and
//! the kernels move only the remainder: a step's displacement of 1e-9 m is then kept
//! instead of being rounded away against a coordinate of 0.05 m.

use super::bindings::{self as b, Holder, Lane};
use super::device::GpuContext;
use super::memory::{self, MemoryPlan};
use super::row_slots;
use crate::effects::rolling_resistance::physics::RollingModel;
use crate::error::{GpuError, Result};
use crate::model::Model;
use crate::physics::contact_law::{PairParams, PairState};
use crate::physics::Vec3;
use crate::plan::StepPlan;
use crate::walls::{WallMotion, WallShape};
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

/// Scene constants (`Params` in common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct Params {
    pub n: u32,
    pub nw: u32,
    pub nmat: u32,
    pub max_events: u32,
    pub dt: f32,
    pub local_damping: f32,
    pub max_overlap_ratio: f32,
    pub wall_groups: u32,
    pub gravity: [f32; 4],
    pub cap: u32,
    pub buckets: u32,
    pub skin: f32,
    pub cell: f32,
    /// 1.0, opaque to the shader compiler (`ledger_add` in heat_ledger.wgsl).
    pub one: f32,
    /// [`super::walls::blocks`] of the wall-load partials: 0 when they are summed directly.
    pub wall_blocks: u32,
    pub pad: [f32; 2],
    /// A periodic cell's spans, their inverses and its lower faces (zeros without one).
    pub period: [f32; 4],
    pub period_inv: [f32; 4],
    pub period_lo: [f32; 4],
    /// Lees–Edwards shear: this step's offset, the next step's, and the slide γ̇·L_z (zeros
    /// without; `effects::periodic::gpu` writes it before each step).
    pub shear: [f32; 4],
}

/// A wall (`Wall` in common.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
pub struct WallLane {
    pub point: [f32; 4],
    pub normal: [f32; 4],
    pub motion: [f32; 4],
    pub prescribed: [f32; 4],
    pub velocity: [f32; 4],
    pub moved: [f32; 4],
    pub load: [f32; 4],
    pub load2: [f32; 4],
}

/// Slots of the counters buffer (C_* in common.wgsl).
pub const C_STEP: usize = 0;
pub const C_EVENTS: usize = 1;
pub const C_DRIFT: usize = 2;
pub const C_SPEED: usize = 3;
pub const C_GUARD: usize = 4;
pub const C_LONGEST: usize = 8;
pub const C_CROWDED: usize = 9;
/// The guard's fifth finding: the lowest particle in a contact too stiff for dt.
pub const C_STIFF: usize = 10;
/// The pore_flow stage: the batch's smallest stable flow step (f32 bits, minimum).
pub const C_PORE_STEP: usize = 11;
/// The pore_flow stage: the largest squared drift since the network's build (f32 bits, maximum).
pub const C_PORE_DRIFT: usize = 12;
/// The pore_flow stage with the fluid's temperature: the batch's smallest stable step of the
/// fluid–grain heat exchange (f32 bits, minimum).
pub const C_PORE_EXCHANGE: usize = 13;
pub const COUNTERS: usize = 14;

const ZERO: Vec3 = Vec3::new(0.0, 0.0, 0.0);

fn v4(v: &Vec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn pair_lane(p: &PairParams) -> [f32; 12] {
    let f = |x: f64| x as f32;
    [
        f(p.kn),
        f(p.ks),
        f(p.breaking_force),
        f(p.fs0),
        f(p.mu),
        f(p.e_star),
        f(p.g_star),
        f(p.zeta),
        f(p.alpha),
        0.0,
        0.0,
        0.0,
    ]
}

/// The model's particles, rows and walls as f32 lanes, ready to upload. Rows are in slots:
/// entry k of particle i at i·cap + k, `row_len[i]` of them in use.
pub struct HostLanes {
    pub origin: Vec<[f32; 4]>,
    pub disp: Vec<[f32; 4]>,
    pub vel: Vec<[f32; 4]>,
    pub body: Vec<[f32; 4]>,
    pub kind: Vec<u32>,
    /// Each element's clump (one word, unread, while the model has none).
    pub clump_of: Vec<u32>,
    pub force: Vec<[f32; 4]>,
    pub ang_vel: Vec<[f32; 4]>,
    pub torque: Vec<[f32; 4]>,
    /// The accumulated rotation at the upload, in f64 (empty without rotation): the device's
    /// angle lane starts at zero and counts the rotation since, as the displacement counts the
    /// move since the origin, and a download adds the two.
    pub angle0: Vec<Vec3>,
    pub built: Vec<[f32; 4]>,
    pub row_len: Vec<u32>,
    pub other: Vec<u32>,
    pub state: Vec<[f32; 4]>,
    pub wall_state: Vec<[f32; 4]>,
    pub walls: Vec<WallLane>,
    pub pairs: Vec<[f32; 12]>,
    pub wall_pairs: Vec<[f32; 12]>,
    /// Per entry, in the rows' slots: the dashpot force of the last step (empty without a dashpot).
    pub dashpot: Vec<f32>,
    /// Per entry, in the rows' slots, and per particle and wall: the epsd rolling springs (empty
    /// without epsd).
    pub rolling: Vec<[f32; 4]>,
    pub wall_rolling: Vec<[f32; 4]>,
    /// Heat ledger slots per particle ([`crate::effects::heat_ledger::gpu::Layout`]).
    pub heat_lanes: usize,
}

impl HostLanes {
    /// Converts the model (rows must be current) for a device run with `plan`, its rows in
    /// slots of `cap` and `heat_lanes` ledger slots a particle. `damping_rate[i]` is c_i/m_i
    /// of the viscous damping (empty when off).
    pub fn from_model(m: &Model, plan: &StepPlan, damping_rate: &[f64], cap: usize, heat_lanes: usize) -> Self {
        let p = &m.particles;
        let n = p.len();
        let mut origin = Vec::with_capacity(n);
        let mut disp = Vec::with_capacity(n);
        let mut built = Vec::with_capacity(n);
        for i in 0..n {
            let x = p.pos[i];
            let o = Vec3::new(f64::from(x.x as f32), f64::from(x.y as f32), f64::from(x.z as f32));
            origin.push(v4(&o, p.radius[i] as f32));
            disp.push(v4(&(x - o), 0.0));
            built.push(v4(&(m.contacts.built_at[i] - o), 0.0));
        }
        let body =
            (0..n).map(|i| [p.mass[i] as f32, damping_rate.get(i).copied().unwrap_or(0.0) as f32, 0.0, 0.0]).collect();
        let kind = (0..n).map(|i| p.material[i] | (u32::from(p.fixed[i]) << 24)).collect();
        let (ang_vel, torque, angle0) = match (&p.rotation, plan.rotation) {
            (Some(r), true) => (
                r.ang_vel.iter().map(|w| v4(w, 0.0)).collect(),
                r.torque.iter().map(|t| v4(t, 0.0)).collect(),
                r.angle.clone(),
            ),
            _ => (Vec::new(), Vec::new(), Vec::new()),
        };
        let epsd = plan.rolling.is_some_and(|r| r.model == RollingModel::Epsd);
        let slots = row_slots::to_slots(&m.contacts, n, cap, plan.dashpot, epsd);
        let wall_rolling = match (epsd, m.wall_rolling.len() == n * m.walls.len()) {
            (false, _) => Vec::new(),
            (true, true) => m.wall_rolling.iter().map(|s| v4(s, 0.0)).collect(),
            (true, false) => vec![[0.0; 4]; n * m.walls.len()],
        };
        let walls = m
            .walls
            .iter()
            .map(|w| {
                // A cone's length and rod end ride in the w lanes of `prescribed` and `velocity`.
                let (point, normal, cone_h, cone_end) = match &w.shape {
                    WallShape::Plane { point, normal } => (v4(point, 0.0), v4(normal, 0.0), 0.0, 0.0),
                    WallShape::Cylinder { center, radius } => {
                        (v4(center, *radius as f32), [0.0, 0.0, 1.0, 1.0], 0.0, 0.0)
                    }
                    WallShape::Cone { apex, axis, half_angle, radius, rod_length } => {
                        let h = radius / half_angle.tan();
                        (v4(apex, *radius as f32), v4(axis, 2.0), h as f32, (h + rod_length) as f32)
                    }
                    // A strip's axis rides in the w lanes of point, prescribed and velocity.
                    WallShape::Strip { point, normal, axis, .. } => {
                        (v4(point, axis.x as f32), v4(normal, 3.0), axis.y as f32, axis.z as f32)
                    }
                };
                let (kind, mut stress, mut max_speed, prescribed) = match &w.motion {
                    WallMotion::Fixed => (0.0, 0.0, 0.0, Vec3::zeros()),
                    WallMotion::Velocity(v) => (1.0, 0.0, 0.0, *v),
                    WallMotion::Servo { stress, max_speed } => (2.0, *stress as f32, *max_speed as f32, Vec3::zeros()),
                };
                // A strip is never a servo (hosts refuse it): its ends ride in the servo's lanes.
                if let WallShape::Strip { lo, hi, .. } = &w.shape {
                    (stress, max_speed) = (*lo as f32, *hi as f32);
                }
                WallLane {
                    point,
                    normal,
                    motion: [kind, stress, max_speed, w.area as f32],
                    prescribed: v4(&prescribed, cone_h),
                    // A fixed wall is at rest, whatever it did before: the walls stage, which
                    // would say so at the first step, does not run in a scene whose walls never
                    // move.
                    velocity: v4(if w.motion == WallMotion::Fixed { &ZERO } else { &w.velocity }, cone_end),
                    moved: [0.0; 4],
                    load: v4(&w.force, w.normal_force as f32),
                    load2: match &w.shape {
                        WallShape::Cone { .. } => {
                            [w.stiffness as f32, w.contacts as f32, w.tip_force as f32, w.sleeve_force as f32]
                        }
                        _ => [w.stiffness as f32, w.contacts as f32, w.damping as f32, 0.0],
                    },
                }
            })
            .collect();
        HostLanes {
            origin,
            disp,
            vel: p.vel.iter().map(|v| v4(v, 0.0)).collect(),
            body,
            kind,
            clump_of: match m.clumps.is_empty() {
                true => vec![crate::effects::clumps::lanes::NONE],
                false => {
                    (0..n).map(|i| m.clumps.of.get(i).copied().unwrap_or(crate::effects::clumps::lanes::NONE)).collect()
                }
            },
            force: p.force.iter().map(|f| v4(f, 0.0)).collect(),
            ang_vel,
            torque,
            angle0,
            built,
            row_len: slots.row_len,
            other: slots.other,
            state: slots.state,
            dashpot: slots.dashpot,
            rolling: slots.rolling,
            wall_rolling,
            // A wall contact is never bonded: w carries its dashpot force.
            wall_state: m.wall_contacts.iter().map(|s| v4(&s.shear, s.dashpot)).collect(),
            walls,
            pairs: plan.pair.iter().map(pair_lane).collect(),
            wall_pairs: plan.wall.iter().map(pair_lane).collect(),
            heat_lanes,
        }
    }
}

/// One slab's per-entry lanes: the rows and contact states of particles `first..first + count`.
pub struct SlabLanes {
    pub first: usize,
    pub count: usize,
    /// `Slab` in common.wgsl.
    pub uniform: wgpu::Buffer,
    pub other: wgpu::Buffer,
    pub state: wgpu::Buffer,
    pub wall_state: wgpu::Buffer,
    /// The pairs' dashpot forces (a placeholder without a dashpot).
    pub dashpot: wgpu::Buffer,
    /// The epsd rolling springs of the pairs and of the wall contacts (placeholders without epsd).
    pub rolling: wgpu::Buffer,
    pub wall_rolling: wgpu::Buffer,
}

/// Creates a storage buffer named `lane` holding `data`, adding its size to `bytes`. A binding
/// may not be empty, so an empty lane gets `placeholder` zero bytes (at least the largest
/// element a shader reads from it); a lane over `limit` bytes is refused.
pub(crate) fn storage_lane(
    ctx: &GpuContext,
    lane: &'static str,
    data: &[u8],
    placeholder: usize,
    limit: u64,
    bytes: &mut u64,
) -> Result<wgpu::Buffer> {
    let zeros = vec![0u8; placeholder];
    let contents = if data.is_empty() { &zeros[..] } else { data };
    if contents.len() as u64 > limit {
        return Err(GpuError::BufferTooLarge { lane, bytes: contents.len() as u64, limit }.into());
    }
    *bytes += contents.len() as u64;
    Ok(ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(lane), contents, usage: STORAGE }))
}

/// One level of the cell list's prefix scan (`ScanLevel` in scan.wgsl) and its workgroups.
pub struct ScanLevel {
    pub uniform: wgpu::Buffer,
    pub workgroups: usize,
}

impl Holder for SlabLanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        Some(match lane {
            b::SLAB => &self.uniform,
            b::OTHER => &self.other,
            b::STATE => &self.state,
            b::WALL_STATE => &self.wall_state,
            b::DASHPOT => &self.dashpot,
            b::ROLLING => &self.rolling,
            b::WALL_ROLLING => &self.wall_rolling,
            _ => return None,
        })
    }
}

impl Holder for ScanLevel {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        (lane == b::SCAN_LEVEL).then_some(&self.uniform)
    }
}

/// The device buffers. Lanes a plan does not use (rotation off, no walls) are 128-byte
/// placeholders, so every kernel binds the same layout.
pub struct DeviceLanes {
    pub n: usize,
    pub plan: MemoryPlan,
    pub params: wgpu::Buffer,
    pub origin: wgpu::Buffer,
    pub disp: wgpu::Buffer,
    pub vel: wgpu::Buffer,
    pub body: wgpu::Buffer,
    pub kind: wgpu::Buffer,
    pub clump_of: wgpu::Buffer,
    pub force: wgpu::Buffer,
    pub ang_vel: wgpu::Buffer,
    pub torque: wgpu::Buffer,
    /// The rotation since the upload (rad), zero at upload ([`HostLanes::angle0`]).
    pub angle: wgpu::Buffer,
    pub built: wgpu::Buffer,
    pub row_len: wgpu::Buffer,
    pub slabs: Vec<SlabLanes>,
    /// The cell list: bucket counts (zero between builds), the scan (bucket starts first,
    /// then the levels above), and the particles in bucket order.
    pub bucket_count: wgpu::Buffer,
    pub scan: wgpu::Buffer,
    pub scan_levels: Vec<ScanLevel>,
    pub cell_items: wgpu::Buffer,
    pub walls: wgpu::Buffer,
    pub pairs: wgpu::Buffer,
    pub wall_pairs: wgpu::Buffer,
    pub partials: wgpu::Buffer,
    /// The partials summed 64 workgroups at a time (walls.wgsl `fold_partials`).
    pub folded: wgpu::Buffer,
    pub counters: wgpu::Buffer,
    pub events: wgpu::Buffer,
    /// The heat ledger ([`crate::effects::heat_ledger`]), zero at upload.
    pub heat: wgpu::Buffer,
    /// Bytes of all device buffers.
    pub bytes: u64,
}

const STORAGE: wgpu::BufferUsages =
    wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST).union(wgpu::BufferUsages::COPY_SRC);

/// A scan level's `ScanLevel` (scan.wgsl): where it starts, its length, where its sums go.
const NO_SUMS: u32 = u32::MAX;

impl DeviceLanes {
    /// Uploads `h` as `plan` lays it out. Refuses a lane larger than `limit` bytes (the
    /// plan has already split what can be split).
    pub fn upload(ctx: &GpuContext, h: &HostLanes, params: Params, plan: &MemoryPlan, limit: u64) -> Result<Self> {
        let mut bytes = 0u64;
        // An empty lane still needs a buffer to bind, as large as the largest element a shader
        // reads from one (a wall, 128 bytes).
        let mut make = |lane: &'static str, data: &[u8]| storage_lane(ctx, lane, data, 128, limit, &mut bytes);
        let n = h.origin.len();
        let (cap, nw) = (plan.cap, h.walls.len());
        let counters = initial_counters();
        let mut slabs = Vec::new();
        for r in plan.slabs() {
            slabs.push(SlabLanes {
                first: r.start,
                count: r.len(),
                uniform: uniform(ctx, "slab", &[r.start as u32, r.len() as u32, 0, 0]),
                other: make("neighbour ids", bytes_of(&row_slots::by_rank(&h.other[r.start * cap..r.end * cap], cap)))?,
                state: make("pair state", bytes_of(&row_slots::by_rank(&h.state[r.start * cap..r.end * cap], cap)))?,
                wall_state: make(
                    "wall contact state",
                    bytes_of(&row_slots::by_rank(&h.wall_state[r.start * nw..r.end * nw], nw)),
                )?,
                dashpot: if h.dashpot.is_empty() {
                    make("dashpot forces", &[])?
                } else {
                    make("dashpot forces", bytes_of(&row_slots::by_rank(&h.dashpot[r.start * cap..r.end * cap], cap)))?
                },
                rolling: if h.rolling.is_empty() {
                    make("rolling springs", &[])?
                } else {
                    make("rolling springs", bytes_of(&row_slots::by_rank(&h.rolling[r.start * cap..r.end * cap], cap)))?
                },
                wall_rolling: if h.wall_rolling.is_empty() {
                    make("wall rolling springs", &[])?
                } else {
                    make(
                        "wall rolling springs",
                        bytes_of(&row_slots::by_rank(&h.wall_rolling[r.start * nw..r.end * nw], nw)),
                    )?
                },
            });
        }
        let levels = memory::scan_levels(n);
        let mut offsets = vec![0usize];
        for len in &levels {
            offsets.push(offsets.last().expect("starts at 0") + len);
        }
        let scan_levels = levels
            .iter()
            .enumerate()
            .map(|(l, &len)| {
                let sums = if l + 1 < levels.len() { offsets[l + 1] as u32 } else { NO_SUMS };
                ScanLevel {
                    uniform: uniform(ctx, "scan level", &[offsets[l] as u32, len as u32, sums, 0]),
                    workgroups: len.div_ceil(memory::SCAN_BLOCK),
                }
            })
            .collect();
        let lanes = DeviceLanes {
            n,
            plan: plan.clone(),
            origin: make("origin", bytes_of(&h.origin))?,
            disp: make("displacement", bytes_of(&h.disp))?,
            vel: make("velocity", bytes_of(&h.vel))?,
            body: make("body", bytes_of(&h.body))?,
            kind: make("kind", bytes_of(&h.kind))?,
            clump_of: make("clump of", bytes_of(&h.clump_of))?,
            force: make("force", bytes_of(&h.force))?,
            ang_vel: make("angular velocity", bytes_of(&h.ang_vel))?,
            torque: make("torque", bytes_of(&h.torque))?,
            angle: make("rotation angle", &vec![0u8; 16 * h.angle0.len()])?,
            built: make("row build positions", bytes_of(&h.built))?,
            row_len: make("row lengths", bytes_of(&h.row_len))?,
            slabs,
            bucket_count: make("cell list", &vec![0u8; 4 * (memory::buckets(n) + 1)])?,
            scan: make("cell list", &vec![0u8; 4 * offsets.last().expect("one level at least")])?,
            scan_levels,
            cell_items: make("cell list", &vec![0u8; 4 * n])?,
            walls: make("walls", bytes_of(&h.walls))?,
            pairs: make("pair constants", bytes_of(&h.pairs))?,
            wall_pairs: make("wall constants", bytes_of(&h.wall_pairs))?,
            partials: make("wall load partials", bytes_of(&initial_partials(h, params.wall_groups as usize)))?,
            folded: make(
                "wall load partials, folded",
                &vec![0u8; params.wall_blocks.max(1) as usize * h.walls.len().max(1) * 32],
            )?,
            counters: make("counters", bytes_of(&counters))?,
            events: make("breakage events", &vec![0u8; plan.max_events * 16])?,
            params: ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            }),
            heat: make("heat ledger", &vec![0u8; n * h.heat_lanes * 8])?,
            bytes: 0,
        };
        Ok(DeviceLanes { bytes: bytes + std::mem::size_of::<Params>() as u64, ..lanes })
    }
}

impl Holder for DeviceLanes {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        Some(match lane {
            b::PARAMS => &self.params,
            b::ORIGIN => &self.origin,
            b::DISP => &self.disp,
            b::VEL => &self.vel,
            b::BODY => &self.body,
            b::KIND => &self.kind,
            b::CLUMP_OF => &self.clump_of,
            b::FORCE => &self.force,
            b::ANG_VEL => &self.ang_vel,
            b::TORQUE => &self.torque,
            b::ANGLE => &self.angle,
            b::BUILT => &self.built,
            b::ROW_LEN => &self.row_len,
            b::BUCKET_COUNT => &self.bucket_count,
            b::CELL_START | b::SCAN_DATA => &self.scan,
            b::CELL_ITEMS => &self.cell_items,
            b::WALLS => &self.walls,
            b::PAIRS => &self.pairs,
            b::WALL_PAIRS => &self.wall_pairs,
            b::PARTIALS => &self.partials,
            b::FOLDED => &self.folded,
            b::COUNTERS => &self.counters,
            b::EVENTS => &self.events,
            b::HEAT => &self.heat,
            _ => return None,
        })
    }
}

/// The counters as an upload leaves them: no step, no event, the minima at their top.
pub fn initial_counters() -> [u32; COUNTERS] {
    let mut counters = [0u32; COUNTERS];
    counters[C_GUARD..C_GUARD + 4].fill(u32::MAX);
    counters[C_STIFF] = u32::MAX;
    counters[C_PORE_STEP] = u32::MAX;
    counters[C_PORE_EXCHANGE] = u32::MAX;
    counters
}

fn uniform(ctx: &GpuContext, label: &str, words: &[u32; 4]) -> wgpu::Buffer {
    ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::cast_slice(words),
        usage: wgpu::BufferUsages::UNIFORM,
    })
}

/// The wall-load partials before the first step: the first workgroup's hold the model's last
/// loads, so the first walls stage of a run sums them back exactly and moves the walls as
/// the CPU would from them.
fn initial_partials(h: &HostLanes, wall_groups: usize) -> Vec<[f32; 4]> {
    let nw = h.walls.len();
    let mut p = vec![[0.0f32; 4]; wall_groups.max(1) * nw * 2];
    for (w, wall) in h.walls.iter().enumerate() {
        let l = wall.load;
        // Partials hold the force on the particles: the opposite of the wall's load.
        p[w * 2] = [-l[0], -l[1], -l[2], l[3]];
        p[w * 2 + 1] = wall.load2;
    }
    p
}

fn bytes_of<T: Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

/// Copies the first `count` elements of `buffer` back to the host (blocking).
pub fn read<T: Pod>(ctx: &GpuContext, buffer: &wgpu::Buffer, count: usize) -> Result<Vec<T>> {
    let mut rb = Readback::default();
    let part = rb.add::<T>(buffer, count);
    Ok(rb.fetch(ctx)?.take(part))
}

/// Buffers copied back to the host together: one submission and one wait for them all, so a
/// download's dozen lanes cost one round trip to the device instead of a dozen (on a hardware
/// GPU each costs a submission, a map and a wait, whatever its size).
#[derive(Default)]
pub struct Readback<'b> {
    /// Each part's buffer and bytes.
    parts: Vec<(&'b wgpu::Buffer, u64)>,
}

/// A part of a [`Readback`], by which its contents are taken from the [`Fetched`] words.
#[derive(Debug, Clone, Copy)]
pub struct Part(usize);

/// What a [`Readback`] brought back: its parts one after another, as 4-byte words (every lane's
/// element is a whole number of them).
pub struct Fetched {
    words: Vec<u32>,
    spans: Vec<std::ops::Range<usize>>,
}

impl<'b> Readback<'b> {
    /// Asks for the first `count` elements of `buffer`.
    pub fn add<T: Pod>(&mut self, buffer: &'b wgpu::Buffer, count: usize) -> Part {
        self.parts.push((buffer, (count * std::mem::size_of::<T>()) as u64));
        Part(self.parts.len() - 1)
    }

    /// Copies every part back (blocking).
    pub fn fetch(self, ctx: &GpuContext) -> Result<Fetched> {
        let mut spans = Vec::with_capacity(self.parts.len());
        let mut total = 0u64;
        for (_, bytes) in &self.parts {
            debug_assert!(bytes.is_multiple_of(4), "lanes are made of 4-byte words");
            spans.push((total / 4) as usize..((total + bytes) / 4) as usize);
            total += bytes;
        }
        if total == 0 {
            return Ok(Fetched { words: Vec::new(), spans });
        }
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: total,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        for ((buffer, bytes), span) in self.parts.iter().zip(&spans) {
            if *bytes > 0 {
                enc.copy_buffer_to_buffer(buffer, 0, &staging, 4 * span.start as u64, *bytes);
            }
        }
        ctx.submit(enc);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        ctx.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Device(e.to_string()))?;
        rx.recv()
            .map_err(|e| GpuError::Device(e.to_string()))?
            .map_err(|e| GpuError::Device(format!("reading a buffer back: {e}")))?;
        let view = staging.get_mapped_range(..).map_err(|e| GpuError::Device(format!("{e:?}")))?;
        let words = bytemuck::cast_slice::<u8, u32>(&view).to_vec();
        drop(view);
        staging.unmap();
        Ok(Fetched { words, spans })
    }
}

impl Fetched {
    /// A part's elements.
    pub fn take<T: Pod>(&self, part: Part) -> Vec<T> {
        bytemuck::cast_slice::<u32, T>(&self.words[self.spans[part.0].clone()]).to_vec()
    }
}

/// A slab's lanes in a download's [`Readback`].
struct SlabParts {
    other: Part,
    state: Part,
    dashpot: Option<Part>,
    wall_state: Part,
    /// The epsd rolling springs of the row entries and of the wall contacts.
    rolling: Option<(Part, Part)>,
}

/// Writes the device's state back into the model: positions (origin + displacement, in f64),
/// velocities, forces, angular lanes, the rows with their pair states (as the device last
/// built them), wall-contact states, walls and their loads.
pub fn download(ctx: &GpuContext, d: &DeviceLanes, h: &mut HostLanes, m: &mut Model, rotation: bool) -> Result<()> {
    let n = d.n;
    let cap = d.plan.cap;
    let nw = h.walls.len();
    let epsd = !h.wall_rolling.is_empty() || !h.rolling.is_empty();
    // Every lane in one round trip.
    let mut rb = Readback::default();
    let disp = rb.add::<[f32; 4]>(&d.disp, n);
    let vel = rb.add::<[f32; 4]>(&d.vel, n);
    let force = rb.add::<[f32; 4]>(&d.force, n);
    let spin = rotation.then(|| {
        (rb.add::<[f32; 4]>(&d.ang_vel, n), rb.add::<[f32; 4]>(&d.torque, n), rb.add::<[f32; 4]>(&d.angle, n))
    });
    let slabs: Vec<SlabParts> = d
        .slabs
        .iter()
        .map(|s| SlabParts {
            other: rb.add::<u32>(&s.other, s.count * cap),
            state: rb.add::<[f32; 4]>(&s.state, s.count * cap),
            // The dashpot forces go back too, so a CPU run continues the trapezoid.
            dashpot: (!h.dashpot.is_empty()).then(|| rb.add::<f32>(&s.dashpot, s.count * cap)),
            wall_state: rb.add::<[f32; 4]>(&s.wall_state, s.count * nw),
            rolling: epsd.then(|| {
                (rb.add::<[f32; 4]>(&s.rolling, s.count * cap), rb.add::<[f32; 4]>(&s.wall_rolling, s.count * nw))
            }),
        })
        .collect();
    let row_len = rb.add::<u32>(&d.row_len, n);
    let built = rb.add::<[f32; 4]>(&d.built, n);
    let walls = rb.add::<WallLane>(&d.walls, nw);
    let got = rb.fetch(ctx)?;
    let disp: Vec<[f32; 4]> = got.take(disp);
    let vel: Vec<[f32; 4]> = got.take(vel);
    let force: Vec<[f32; 4]> = got.take(force);
    let to64 = |a: &[f32; 4]| Vec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
    let p = &mut m.particles;
    for i in 0..n {
        p.pos[i] = to64(&h.origin[i]) + to64(&disp[i]);
        p.vel[i] = to64(&vel[i]);
        p.force[i] = to64(&force[i]);
    }
    if let Some((w, t, a)) = spin {
        let w: Vec<[f32; 4]> = got.take(w);
        let t: Vec<[f32; 4]> = got.take(t);
        let a: Vec<[f32; 4]> = got.take(a);
        if let Some(r) = &mut p.rotation {
            for i in 0..n {
                r.ang_vel[i] = to64(&w[i]);
                r.torque[i] = to64(&t[i]);
                // The device's rotation since the upload, added to the angle then in f64.
                r.angle[i] = h.angle0[i] + to64(&a[i]);
            }
        }
    }
    let mut other = Vec::with_capacity(n * cap);
    let mut state = Vec::with_capacity(n * cap);
    let mut dashpot = Vec::with_capacity(if h.dashpot.is_empty() { 0 } else { n * cap });
    let mut wall_state = Vec::with_capacity(n * nw);
    let (mut rolling, mut wall_rolling) = (Vec::new(), Vec::new());
    for s in &slabs {
        other.extend(row_slots::by_row(&got.take::<u32>(s.other), cap));
        state.extend(row_slots::by_row(&got.take::<[f32; 4]>(s.state), cap));
        if let Some(part) = s.dashpot {
            dashpot.extend(row_slots::by_row(&got.take::<f32>(part), cap));
        }
        wall_state.extend(row_slots::by_row(&got.take::<[f32; 4]>(s.wall_state), nw));
        if let Some((row, wall)) = s.rolling {
            rolling.extend(row_slots::by_row(&got.take::<[f32; 4]>(row), cap));
            wall_rolling.extend(row_slots::by_row(&got.take::<[f32; 4]>(wall), nw));
        }
    }
    let slots = row_slots::Slots { cap, row_len: got.take(row_len), other, state, dashpot, rolling };
    let built: Vec<[f32; 4]> = got.take(built);
    let built_at = (0..n).map(|i| to64(&h.origin[i]) + to64(&built[i])).collect();
    row_slots::into_contacts(&slots, built_at, &mut m.contacts);
    for (s, g) in m.wall_contacts.iter_mut().zip(&wall_state) {
        *s = PairState { shear: to64(g), dashpot: g[3], ..PairState::default() };
    }
    if epsd {
        m.wall_rolling = wall_rolling.iter().map(to64).collect();
    }
    let walls: Vec<WallLane> = got.take(walls);
    for ((w, g), seen) in m.walls.iter_mut().zip(&walls).zip(&mut h.walls) {
        // The device's move since the upload, less what an earlier download of this session
        // already added (the session may continue after a download).
        let moved = to64(&g.moved) - to64(&seen.moved);
        seen.moved = g.moved;
        match &mut w.shape {
            // The host's shape is the one uploaded: add the device's move to it in f64.
            WallShape::Plane { point, .. } => *point += moved,
            WallShape::Cylinder { radius, .. } => *radius += moved.x,
            WallShape::Cone { apex, .. } => *apex += moved,
            WallShape::Strip { point, .. } => *point += moved,
        }
        w.displacement += moved;
        w.velocity = to64(&g.velocity);
        w.force = to64(&g.load);
        w.normal_force = f64::from(g.load[3]);
        w.stiffness = f64::from(g.load2[0]);
        w.contacts = g.load2[1] as u32;
        // A cone's z and w lanes are its tip and sleeve loads; other walls' z is Σc.
        if let WallShape::Cone { .. } = &w.shape {
            w.tip_force = f64::from(g.load2[2]);
            w.sleeve_force = f64::from(g.load2[3]);
        } else {
            w.damping = f64::from(g.load2[2]);
        }
    }
    Ok(())
}
