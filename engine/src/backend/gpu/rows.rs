//! The `neighbours` stage on the GPU: neighbour rows built on the device when the drift says so,
//! with the content and order of the host's [`rebuild`](crate::neighbours::rebuild), so a rebuild
//! costs no trip through the host. A build is a cell list (shaders/cell_list.wgsl: cells hashed
//! into a table, counted, scanned into starts by shaders/scan.wgsl, filled) and one invocation per
//! particle collecting, sorting and carrying its row (shaders/rows.wgsl), in a counting pass and a
//! writing pass. When a new row would not fit its slots, or carries more set states than the kernel
//! holds, nothing is written and the host builds the rows instead (and lays the slots out wider).
//!
//! Also the conversions between the host's CSR rows and the device's fixed-width slots.

use super::bindings::{BUCKET_COUNT, DISP, ORIGIN, PARAMS};
use super::buffers::{DeviceLanes, ScanLevel, C_CROWDED, C_LONGEST};
use super::device::GpuContext;
use super::shaders::{self, grid, groups_for, Kernel, Pipeline};
use crate::error::Result;
use crate::physics::contact_law::PairState;
use crate::physics::Vec3;
use crate::state::contacts::Contacts;

/// Rows in fixed-width slots, row by row: entry k of particle i at `i * cap + k`, `row_len[i]`
/// in use. The device keeps each slab's slots rank by rank instead ([`by_rank`]).
pub struct Slots {
    pub cap: usize,
    pub row_len: Vec<u32>,
    pub other: Vec<u32>,
    pub state: Vec<[f32; 4]>,
    /// The pairs' dashpot forces of the last step; empty when the plan has no dashpot.
    pub dashpot: Vec<f32>,
    /// The pairs' epsd rolling springs; empty unless the plan has epsd.
    pub rolling: Vec<[f32; 4]>,
}

/// The host's rows (`n` of them, each at most `cap` long) in slots; states in f32, dashpot
/// forces only when `dashpot`, epsd rolling springs only when `rolling` (zero where the host's
/// rows have none).
pub fn to_slots(c: &Contacts, n: usize, cap: usize, dashpot: bool, rolling: bool) -> Slots {
    let mut s = Slots {
        cap,
        row_len: vec![0; n],
        other: vec![0; n * cap],
        state: vec![[0.0; 4]; n * cap],
        dashpot: if dashpot { vec![0.0; n * cap] } else { Vec::new() },
        rolling: if rolling { vec![[0.0; 4]; n * cap] } else { Vec::new() },
    };
    let springs = rolling && c.rolling.len() == c.other.len();
    for i in 0..n.min(c.row_start.len().saturating_sub(1)) {
        let row = c.row(i);
        s.row_len[i] = row.len() as u32;
        for (k, e) in row.enumerate() {
            let st = &c.state[e];
            s.other[i * cap + k] = c.other[e];
            // w: 0 unbonded, else the bond's share of its strength (1 unless a joint weakened it).
            let w = if st.bonded { st.strength() as f32 } else { 0.0 };
            s.state[i * cap + k] = [st.shear.x as f32, st.shear.y as f32, st.shear.z as f32, w];
            if dashpot {
                s.dashpot[i * cap + k] = st.dashpot;
            }
            if springs {
                let r = &c.rolling[e];
                s.rolling[i * cap + k] = [r.x as f32, r.y as f32, r.z as f32, 0.0];
            }
        }
    }
    s
}

/// A slab's slots as the host holds them, row by row (`count` rows of `cap`), laid rank by
/// rank as the device keeps them: entry k of row r at k·count + r (`row_slot` in
/// common.wgsl), so that a warp's invocations, which hold neighbouring rows, read neighbouring
/// words at each entry.
pub fn by_rank<T: Copy>(rows: &[T], cap: usize) -> Vec<T> {
    let count = rows.len() / cap.max(1);
    (0..rows.len()).map(|slot| rows[(slot % count) * cap + slot / count]).collect()
}

/// A slab's slots as the device keeps them (rank by rank), back row by row: [`by_rank`]
/// undone.
pub fn by_row<T: Copy>(ranks: &[T], cap: usize) -> Vec<T> {
    let count = ranks.len() / cap.max(1);
    (0..ranks.len()).map(|slot| ranks[(slot % cap) * count + slot / cap]).collect()
}

/// Replaces the rows of `c` by the slots' (built at `built_at`), with the pair ids the host's
/// rebuild would give them: pairs numbered by (lower id, higher id). The wall mask is left
/// to the caller, which knows the walls.
pub fn into_contacts(s: &Slots, built_at: Vec<Vec3>, c: &mut Contacts) {
    let n = s.row_len.len();
    let mut row_start = Vec::with_capacity(n + 1);
    row_start.push(0u32);
    let mut other = Vec::new();
    let mut state = Vec::new();
    let mut rolling = Vec::new();
    for i in 0..n {
        let slots = i * s.cap..i * s.cap + s.row_len[i] as usize;
        if !s.rolling.is_empty() {
            rolling.extend(
                s.rolling[slots.clone()].iter().map(|g| Vec3::new(f64::from(g[0]), f64::from(g[1]), f64::from(g[2]))),
            );
        }
        other.extend_from_slice(&s.other[slots.clone()]);
        state.extend(slots.map(|e| {
            let g = s.state[e];
            PairState {
                shear: Vec3::new(f64::from(g[0]), f64::from(g[1]), f64::from(g[2])),
                bonded: g[3] != 0.0,
                dashpot: s.dashpot.get(e).copied().unwrap_or(0.0),
                // w holds 1 − weakened/65535 in f32 (24 bits): rounding recovers it exactly.
                weakened: if g[3] != 0.0 { PairState::weakened_for(f64::from(g[3])) } else { 0 },
            }
        }));
        row_start.push(other.len() as u32);
    }
    let mut pair = vec![0u32; other.len()];
    let mut pair_start = vec![0u32; n + 1];
    let mut next = 0u32;
    for i in 0..n {
        pair_start[i] = next;
        for e in row_start[i] as usize..row_start[i + 1] as usize {
            let j = other[e] as usize;
            if j > i {
                pair[e] = next;
                // Rows are sorted and mirrored: the twin entry is i in row j.
                let r = row_start[j] as usize..row_start[j + 1] as usize;
                if let Ok(k) = other[r.clone()].binary_search(&(i as u32)) {
                    pair[r.start + k] = next;
                }
                next += 1;
            }
        }
    }
    pair_start[n] = next;
    *c = Contacts {
        row_start,
        other,
        state,
        pair,
        pair_start,
        wall_near: Vec::new(),
        walls_at_build: Vec::new(),
        built_at,
        skin: c.skin,
        stale: false,
        rolling,
    };
}

/// The device build's pipelines.
pub struct Pipelines {
    bin: Pipeline,
    fill: Pipeline,
    scan: Pipeline,
    add_sums: Pipeline,
    count: Pipeline,
    write: Pipeline,
}

pub fn pipelines(device: &GpuContext, constants: &[(&str, f64)]) -> Pipelines {
    let with_write = |on: f64| {
        let mut c = constants.to_vec();
        c.push(("WRITE_ROWS", on));
        c
    };
    Pipelines {
        bin: shaders::pipeline(device, "bin_particles", &shaders::CELL_LIST, "bin_particles", constants),
        fill: shaders::pipeline(device, "fill_cells", &shaders::CELL_LIST, "fill_cells", constants),
        scan: shaders::pipeline(device, "scan_blocks", &shaders::SCAN, "scan_blocks", constants),
        add_sums: shaders::pipeline(device, "add_block_sums", &shaders::SCAN, "add_block_sums", constants),
        count: shaders::pipeline(device, "count_rows", &shaders::ROWS, "build_rows", &with_write(0.0)),
        write: shaders::pipeline(device, "write_rows", &shaders::ROWS, "build_rows", &with_write(1.0)),
    }
}

/// The device build bound to one upload's buffers.
pub struct Kernels {
    bin: Kernel,
    fill: Kernel,
    /// Per scan level, bottom up.
    scan: Vec<Kernel>,
    add_sums: Vec<Kernel>,
    /// Per slab.
    count: Vec<Kernel>,
    write: Vec<Kernel>,
}

pub fn kernels(device: &wgpu::Device, p: &Pipelines, d: &DeviceLanes) -> Result<Kernels> {
    // bin_particles uses only the first four of cell_list.wgsl's bindings.
    let cells = [PARAMS, ORIGIN, DISP, BUCKET_COUNT];
    let level = |pipeline: &Pipeline, l: &ScanLevel| Kernel::bind(device, pipeline, &[d, l], grid(l.workgroups));
    let rows = |pipeline: &Pipeline| -> Result<Vec<Kernel>> {
        d.slabs.iter().map(|s| Kernel::bind(device, pipeline, &[d, s], groups_for(s.count))).collect()
    };
    Ok(Kernels {
        bin: Kernel::bind_lanes(device, &p.bin, &cells, &[d], groups_for(d.n))?,
        fill: Kernel::bind(device, &p.fill, &[d], groups_for(d.n))?,
        scan: d.scan_levels.iter().map(|l| level(&p.scan, l)).collect::<Result<_>>()?,
        add_sums: d.scan_levels.iter().map(|l| level(&p.add_sums, l)).collect::<Result<_>>()?,
        count: rows(&p.count)?,
        write: rows(&p.write)?,
    })
}

impl Kernels {
    /// Encodes one build. The counters C_LONGEST and C_CROWDED must be zero before it.
    pub fn encode(&self, enc: &mut wgpu::CommandEncoder, d: &DeviceLanes) {
        let pass = |label| wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None };
        self.bin.dispatch(&mut enc.begin_compute_pass(&pass("neighbours: bin_particles")));
        // The scan runs in place on a copy of the counts, which fill_cells counts back down.
        enc.copy_buffer_to_buffer(&d.bucket_count, 0, &d.scan, 0, d.bucket_count.size());
        let mut pass = enc.begin_compute_pass(&pass("neighbours: scan, fill_cells, build_rows"));
        for k in &self.scan {
            k.dispatch(&mut pass);
        }
        // Down again: each level but the top gets the scanned sums of the level above.
        for k in self.add_sums.iter().rev().skip(1) {
            k.dispatch(&mut pass);
        }
        self.fill.dispatch(&mut pass);
        for k in self.count.iter().chain(&self.write) {
            k.dispatch(&mut pass);
        }
    }
}

/// What a device build found: whether it wrote the rows, and if not, why.
pub fn verdict(counters: &[u32], cap: usize) -> std::result::Result<(), String> {
    let (longest, crowded) = (counters[C_LONGEST] as usize, counters[C_CROWDED]);
    if crowded > 0 {
        return Err(format!(
            "{crowded} rows carry more than {} contacts and bonds, more than a device build holds",
            super::memory::MAX_CARRY
        ));
    }
    if longest > cap {
        return Err(format!("a row of {longest} neighbours outgrew its {cap} slots"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn slots_go_rank_by_rank_on_the_device_and_back() {
        // Three rows of two: (a0 a1) (b0 b1) (c0 c1) → a0 b0 c0 a1 b1 c1.
        let rows = [10, 11, 20, 21, 30, 31];
        assert_eq!(by_rank(&rows, 2), vec![10, 20, 30, 11, 21, 31]);
        assert_eq!(by_row(&by_rank(&rows, 2), 2), rows.to_vec());
        assert!(by_rank::<u32>(&[], 4).is_empty());
    }

    use super::*;

    fn contacts(rows: &[&[u32]]) -> Contacts {
        let mut c = Contacts::default();
        c.row_start.push(0);
        for (i, r) in rows.iter().enumerate() {
            for &j in *r {
                c.other.push(j);
                let bonded = (i as u32).min(j) == 0;
                // Dashpot forces exact in f32, so the round trip is exact.
                let dashpot = 0.25 * j as f32;
                // Some bonds weakened (a joint), so their share rides along in w.
                let weakened = if bonded && j % 2 == 1 { PairState::weakened_for(0.2) } else { 0 };
                c.state.push(PairState { shear: Vec3::new(i as f64, j as f64, 0.5), bonded, dashpot, weakened });
            }
            c.row_start.push(c.other.len() as u32);
        }
        c
    }

    #[test]
    fn rows_and_dashpot_forces_go_to_slots_and_back_with_the_host_pair_ids() {
        let mut c = contacts(&[&[1, 3], &[0, 2, 3], &[1], &[0, 1]]);
        c.skin = 1e-4;
        assert!(to_slots(&c, 4, 5, false, false).dashpot.is_empty(), "no dashpot lane without a dashpot");
        let s = to_slots(&c, 4, 5, true, false);
        assert_eq!(s.row_len, [2, 3, 1, 2]);
        assert_eq!(&s.other[5..8], [0, 2, 3]);
        assert_eq!(s.state[5], [1.0, 0.0, 0.5, 1.0]);
        assert_eq!(&s.dashpot[5..8], [0.0, 0.5, 0.75]);
        let before = c.clone();
        into_contacts(&s, vec![Vec3::zeros(); 4], &mut c);
        assert_eq!((c.row_start.clone(), c.other.clone()), (before.row_start, before.other));
        assert_eq!(c.state, before.state);
        // Pairs by (lower, higher): (0,1) (0,3) (1,2) (1,3); each pair's two entries share its id.
        assert_eq!(c.pair, [0, 1, 0, 2, 3, 2, 1, 3]);
        assert_eq!(c.pair_start, [0, 2, 4, 4, 4]);
        assert!(c.has_pair_ids() && c.skin == 1e-4 && !c.stale);
    }

    #[test]
    fn a_build_that_did_not_fit_says_why() {
        let mut counters = vec![0u32; super::super::buffers::COUNTERS];
        assert!(verdict(&counters, 8).is_ok());
        counters[C_LONGEST] = 9;
        assert!(verdict(&counters, 8).unwrap_err().contains("row of 9 neighbours outgrew its 8 slots"));
        counters[C_CROWDED] = 2;
        assert!(verdict(&counters, 8).unwrap_err().contains("2 rows carry more than 64"));
    }
}
