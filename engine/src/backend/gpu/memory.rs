//! How a model is laid out in device memory, decided before any buffer is made: the width
//! of the neighbour-row slots, how the per-entry lanes are split into slabs of particles so
//! each slab fits one storage binding, and what the whole takes.
//!
//! Per-particle lanes (16 bytes × N at most, 8 × the heat causes for the heat ledger) are
//! bound whole: any row may read any neighbour's position. Per-entry lanes (neighbour ids,
//! pair state, pair dashpot force, wall contact state) are
//! read only by the particle that owns the entry, so they can live in one buffer per slab
//! and each kernel that reads them runs once per slab. A slab holds a multiple of 64
//! particles, the workgroup size, so the workgroups and their wall-load partials are the
//! same whatever the split: a split run is bitwise the unsplit one.

use crate::error::{GpuError, Result};
use std::ops::Range;

/// Particles per workgroup in every per-particle kernel.
pub const WORKGROUP: usize = 64;
/// Bytes of one pair state or wall contact state (vec4<f32>).
const STATE_BYTES: u64 = 16;
/// Bytes of one heat ledger slot: a compensated (hi, lo) f32 pair.
const HEAT_SLOT_BYTES: u64 = 8;
/// Rows the device builds carry at most this many entries with a set state (a contact or a
/// bond); a row with more is built on the host (see `MAX_CARRY` in rows.wgsl).
pub const MAX_CARRY: usize = 64;

/// The limits the layout must respect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Bytes one storage binding may span.
    pub binding: u64,
    /// Bytes one buffer may hold.
    pub buffer: u64,
}

impl Limits {
    pub fn of(l: &wgpu::Limits) -> Self {
        Limits { binding: l.max_storage_buffer_binding_size, buffer: l.max_buffer_size }
    }

    /// What one lane may hold: a binding, and no more than a buffer.
    fn lane(&self) -> u64 {
        self.binding.min(self.buffer)
    }
}

/// What the layout is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scene {
    pub particles: usize,
    /// The longest neighbour row.
    pub longest_row: usize,
    pub walls: usize,
    pub rotation: bool,
    /// Bonds that may break (each can log one event).
    pub bonds: usize,
    /// Whether pairs carry a dashpot force (4 bytes a row entry).
    pub dashpot: bool,
    /// Heat ledger slots a particle ([`crate::effects::heat_ledger::gpu::Layout::lanes`], 8 bytes each).
    pub heat_lanes: usize,
    /// Whether contacts carry an epsd rolling spring (16 bytes a row entry and a wall).
    pub rolling: bool,
    /// The pore_flow stage's element corners (4 per tetrahedron of the pore network; 0 without
    /// the stage): each element's row of (tetrahedron, corner), 4 bytes an entry, with its row
    /// start and position at the network's build (20 bytes an element).
    pub pore_corners: usize,
    /// The pore fluid has a temperature: each element also keeps its exchange's carry (4 bytes).
    pub pore_heat: bool,
    /// The applied_loads stage's lanes a particle: 0 without it, 1 (forces) or 2 (forces and
    /// torques), a vec4<f32> each.
    pub applied_loads: usize,
}

/// Slot width for rows whose longest is `longest`: room for a quarter more (at least four),
/// and never under [`MIN_SLOTS`], so the rows the device builds as a loose packing settles
/// rarely outgrow the slots (each time they do, the rows go through the host).
pub fn slot_width(longest: usize) -> usize {
    (longest + (longest / 4).max(4)).max(MIN_SLOTS)
}

/// Slots of a row at least: a settled mono-size packing has about 6 contacts and 12 neighbours
/// within a skin of 0.4 radii.
pub const MIN_SLOTS: usize = 16;

/// Hash-table buckets of the device's cell list: a power of two, at least the particle count.
pub fn buckets(particles: usize) -> usize {
    particles.max(WORKGROUP).next_power_of_two()
}

/// Elements of each level of the cell list's prefix scan: the bucket counts (plus one, so
/// the last bucket has an end), then one sum per 256 of the level below, until one
/// workgroup scans the rest.
pub fn scan_levels(particles: usize) -> Vec<usize> {
    let mut levels = vec![buckets(particles) + 1];
    while *levels.last().expect("one level at least") > SCAN_BLOCK {
        levels.push(levels.last().expect("one level at least").div_ceil(SCAN_BLOCK));
    }
    levels
}

/// Elements one workgroup of the scan handles.
pub const SCAN_BLOCK: usize = 256;

/// A model's layout on one device.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MemoryPlan {
    pub particles: usize,
    /// Entries each particle's row has room for.
    pub cap: usize,
    pub walls: usize,
    /// Particles per slab (a multiple of [`WORKGROUP`]); the last slab may hold fewer.
    pub slab: usize,
    /// Bytes of every lane together.
    pub bytes: u64,
    /// Room for this many breakage events per run.
    pub max_events: usize,
}

impl MemoryPlan {
    /// Lays out `scene` under `limits`, or says which lane cannot fit and what to do.
    pub fn new(scene: Scene, limits: Limits) -> Result<Self> {
        let n = scene.particles;
        let cap = slot_width(scene.longest_row);
        let lane = limits.lane();
        // The widest per-entry lane decides how many particles a slab may hold.
        let widest = STATE_BYTES * cap.max(scene.walls).max(1) as u64;
        let per_slab = (lane / widest) as usize / WORKGROUP * WORKGROUP;
        if per_slab == 0 {
            return Err(
                GpuError::BufferTooLarge { lane: "pair state", bytes: widest * WORKGROUP as u64, limit: lane }.into()
            );
        }
        let slab = per_slab.min(n.div_ceil(WORKGROUP).max(1) * WORKGROUP);
        // Per-particle lanes, whole: the widest is 16 bytes a particle.
        let whole = 16 * n as u64;
        if whole > lane {
            return Err(GpuError::BufferTooLarge { lane: "positions", bytes: whole, limit: lane }.into());
        }
        // The scan's levels share one buffer; the bucket counts have their own.
        let scan = 4 * scan_levels(n).iter().sum::<usize>() as u64;
        if scan > lane {
            return Err(GpuError::BufferTooLarge { lane: "cell list", bytes: scan, limit: lane }.into());
        }
        // The heat ledger is one lane bound whole: every cause of a particle side by side.
        let heat = HEAT_SLOT_BYTES * scene.heat_lanes as u64 * n as u64;
        if heat > lane {
            return Err(GpuError::BufferTooLarge { lane: "heat ledger", bytes: heat, limit: lane }.into());
        }
        let table = scan + 4 * (buckets(n) as u64 + 1);
        // One event per bond that may break, as far as one binding holds.
        let max_events = scene.bonds.clamp(1, (lane / 16) as usize);
        let rotation = if scene.rotation { 3 } else { 0 };
        // origin, displacement, velocity, body, force, build position (+ angular velocity, torque,
        // angle).
        // + kind, row length, cell item, and a (hi, lo) f32 pair per heat cause.
        // The pore network's per-element lanes (its per-pore and per-throat lanes are the stage's
        // own, `pore_flow::PoreSession::bytes`).
        let pore = match (scene.pore_corners > 0, scene.pore_heat) {
            (false, _) => 0,
            (true, false) => 4 + 16,
            (true, true) => 4 + 16 + 4,
        };
        let per_particle =
            (6 + rotation + scene.applied_loads) as u64 * 16 + 4 * 3 + HEAT_SLOT_BYTES * scene.heat_lanes as u64 + pore;
        // Neighbour id, pair state (and dashpot force) per slot; a state per wall.
        // (And the epsd rolling spring per slot and per wall.)
        let spring = if scene.rolling { 16 } else { 0 };
        let per_slot = 4 + STATE_BYTES + if scene.dashpot { 4 } else { 0 } + spring;
        let per_entry = per_slot * cap as u64 + (STATE_BYTES + spring) * scene.walls as u64;
        // The wall pass's partials, and the same folded 64 at a time.
        let partials = (n.div_ceil(WORKGROUP) * scene.walls * 32) as u64;
        let partials = partials + partials.div_ceil(64);
        let bytes = n as u64 * (per_particle + per_entry)
            + 4 * scene.pore_corners as u64
            + table
            + partials
            + 16 * max_events as u64;
        Ok(MemoryPlan { particles: n, cap, walls: scene.walls, slab, bytes, max_events })
    }

    /// The particles of each slab.
    pub fn slabs(&self) -> Vec<Range<usize>> {
        let n = self.particles;
        if n == 0 {
            // One empty slab: its placeholder buffers keep every kernel's bindings whole.
            let empty: Range<usize> = 0..0;
            return vec![empty];
        }
        (0..n).step_by(self.slab).map(|a| a..(a + self.slab).min(n)).collect()
    }

    pub fn bytes_per_particle(&self) -> f64 {
        self.bytes as f64 / self.particles.max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// H100-like: 4 GiB - 1 per binding, 64 GiB per buffer.
    const H100: Limits = Limits { binding: (4 << 30) - 1, buffer: 64 << 30 };

    #[test]
    fn fifty_million_bench_particles_fit_an_h100_under_one_kilobyte_each() {
        // The bench lattice: six face neighbours within the skin, five walls, rotation on,
        // no bonds; rows up to 14 long once the lattice settles into a denser packing. Its
        // restitution of 0.5 gives every pair a dashpot force, and its heat ledger books
        // contact damping and friction (two slots; its walls are fixed).
        for longest in [6, 14] {
            let scene = Scene {
                particles: 50_000_000,
                longest_row: longest,
                walls: 5,
                rotation: true,
                bonds: 0,
                dashpot: true,
                heat_lanes: 2,
                rolling: false,
                pore_corners: 0,
                pore_heat: false,
                applied_loads: 0,
            };
            let plan = MemoryPlan::new(scene, H100).unwrap();
            let per = plan.bytes_per_particle();
            let what =
                format!("longest row {longest}: cap {}, {} slabs, {per:.0} B/particle", plan.cap, plan.slabs().len());
            assert!(per <= 1024.0, "{what}");
            assert!(plan.slabs().len() > 1, "12.8 GB of pair state cannot sit in one 4 GiB binding");
            assert!(plan.slab as u64 * 16 * plan.cap as u64 <= H100.binding);
            assert_eq!(plan.slab % WORKGROUP, 0);
            assert_eq!(plan.slabs().last().unwrap().end, 50_000_000);
            // The dashpot force (4 B a slot) and two ledger slots (8 B each) are counted.
            let bare = MemoryPlan::new(Scene { dashpot: false, heat_lanes: 0, ..scene }, H100).unwrap();
            assert_eq!(plan.bytes - bare.bytes, 50_000_000 * (4 * plan.cap as u64 + 2 * 8));
        }
    }

    #[test]
    fn the_pore_networks_element_lanes_are_counted_when_the_stage_is_on() {
        // A packing has about 6.5 tetrahedra an element: 26 corners.
        let scene = Scene {
            particles: 1000,
            longest_row: 12,
            walls: 0,
            rotation: false,
            bonds: 0,
            dashpot: false,
            heat_lanes: 0,
            rolling: false,
            pore_corners: 0,
            pore_heat: false,
            applied_loads: 0,
        };
        let limits = Limits { binding: 1 << 30, buffer: 1 << 30 };
        let bare = MemoryPlan::new(scene, limits).unwrap();
        let pores = MemoryPlan::new(Scene { pore_corners: 26_000, ..scene }, limits).unwrap();
        assert_eq!(pores.bytes - bare.bytes, 1000 * (4 + 16) + 4 * 26_000);
        let heat = MemoryPlan::new(Scene { pore_corners: 26_000, pore_heat: true, ..scene }, limits).unwrap();
        assert_eq!(heat.bytes - pores.bytes, 1000 * 4);
        assert!(pores.bytes_per_particle() - bare.bytes_per_particle() == 124.0);
    }

    #[test]
    fn a_small_binding_splits_the_rows_into_workgroup_slabs() {
        let scene = Scene {
            particles: 1000,
            longest_row: 12,
            walls: 2,
            rotation: false,
            bonds: 10,
            dashpot: true,
            heat_lanes: 5,
            rolling: false,
            pore_corners: 0,
            pore_heat: false,
            applied_loads: 0,
        };
        let plan = MemoryPlan::new(scene, Limits { binding: 64 * 16 * 16 * 3 + 5, buffer: 1 << 30 }).unwrap();
        assert_eq!(plan.cap, 16);
        assert_eq!(plan.slab, 192);
        assert_eq!(plan.slabs().len(), 6);
        assert_eq!(plan.slabs()[5], 960..1000);
    }

    #[test]
    fn a_lane_that_cannot_fit_is_named_with_the_limit() {
        let mut scene = Scene {
            particles: 10_000_000,
            longest_row: 6,
            walls: 0,
            rotation: false,
            bonds: 0,
            dashpot: false,
            heat_lanes: 0,
            rolling: false,
            pore_corners: 0,
            pore_heat: false,
            applied_loads: 0,
        };
        let e = MemoryPlan::new(scene, Limits { binding: 128 << 20, buffer: 1 << 40 }).unwrap_err().to_string();
        assert!(e.contains("`positions`") && e.contains("134217728") && e.contains("fewer particles"), "{e}");
        // Positions fit 256 MiB (160 MB), a ledger of all five causes (400 MB) does not.
        let limits = Limits { binding: 256 << 20, buffer: 1 << 40 };
        assert!(MemoryPlan::new(scene, limits).is_ok());
        scene.heat_lanes = 5;
        let e = MemoryPlan::new(scene, limits).unwrap_err().to_string();
        assert!(e.contains("`heat ledger`") && e.contains("400000000") && e.contains("268435456"), "{e}");
    }
}
