//! The `neighbours` stage on the GPU: neighbour rows built on the device when the drift says so,
//! with the content and order of the host's [`rebuild`](crate::neighbours::rebuild), so a rebuild
//! costs no trip through the host. A build is a cell list (shaders/cell_list.wgsl: cells hashed
//! into a table, counted, scanned into starts by shaders/scan.wgsl, filled) and one invocation per
//! particle collecting, sorting and carrying its row (shaders/rows.wgsl), in a counting pass and a
//! writing pass. When a new row would not fit its slots, or carries more set states than the kernel
//! holds, nothing is written and the host builds the rows instead (and lays the slots out wider).

use super::bindings::{BUCKET_COUNT, DISP, ORIGIN, PARAMS};
use super::buffers::{DeviceLanes, ScanLevel, C_CROWDED, C_LONGEST};
use super::device::GpuContext;
use super::shaders::{self, grid, groups_for, Kernel, Pipeline};
use crate::error::Result;

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
        count: shaders::pipeline(device, "count_rows", &shaders::ROWS, "count_rows", &with_write(0.0)),
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
    use super::*;

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
