//! Where a GPU step's time goes (`bench --profile --backend gpu`): each stage of the plan in
//! its own compute pass, timed on the device by timestamp queries where the adapter has them
//! (else by the host's clock around each pass's submission, which then counts the
//! submission too), beside the bytes each stage binds and the same steps as a run encodes
//! them (a batch of steps in one pass).

use super::buffers::{read, COUNTERS};
use super::{GpuBackend, StageWork, MAX_BATCH, STEP_BATCH};
use crate::error::{Error, GpuError, Result};
use crate::model::Model;
use crate::plan::Stage;
use std::time::Instant;

/// What a profile measured.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuProfile {
    pub particles: usize,
    /// Steps run with each stage in its own pass.
    pub steps: u64,
    /// The stages in step order (the batch's drift measure and guard last), each over the
    /// profiled steps; `neighbours: row builds` when the rows were rebuilt meanwhile.
    pub stages: Vec<StageTime>,
    /// Steps run as a run encodes them (a batch in one pass), each batch after one of the
    /// profiled ones, and their seconds.
    pub batched_steps: u64,
    pub batched_seconds: f64,
    /// How the passes were timed.
    pub clock: ProfileClock,
    /// Compute passes submitted and dispatches, per step, as a run encodes them.
    pub dispatches_per_step: f64,
    pub submissions_per_step: f64,
    /// The device's nominal memory bandwidth (B/s), where its name is known.
    pub nominal_bandwidth: Option<f64>,
}

/// One stage's share of the profiled steps.
#[derive(Debug, Clone, PartialEq)]
pub struct StageTime {
    pub name: &'static str,
    pub seconds: f64,
    /// Bytes of the buffers its kernels bind, summed over its dispatches: an upper bound of
    /// what it moves (a kernel reads a row's lanes only where the row has entries).
    pub bytes: u64,
    pub dispatches: u64,
}

impl GpuProfile {
    /// Seconds of all stages' passes.
    pub fn total(&self) -> f64 {
        self.stages.iter().map(|s| s.seconds).sum()
    }
}

/// How a profile's passes were timed.
#[derive(Debug, Clone, PartialEq)]
pub enum ProfileClock {
    /// The device's timestamp queries, `period` nanoseconds a tick.
    Timestamps { period: f32 },
    /// The host's clock around each pass's submission and wait: the adapter has no timestamp
    /// queries.
    Host,
}

/// The most passes one timed submission holds (two timestamps each, in one query set).
const MAX_PASSES: usize = (wgpu::QUERY_SET_MAX_QUERIES / 2) as usize;

/// The name under which row builds during a profile are booked (host clock: a build is a
/// submission of its own and a read of its verdict).
pub const ROW_BUILDS: &str = "neighbours: row builds";

impl GpuBackend {
    /// Runs `steps` steps of `m` with each stage in its own pass, timed, each batch followed by
    /// one as a run encodes it, timed the same way; the model stays on the device afterwards
    /// (a later run or sync continues from it). The pore network's stage is not profiled.
    pub fn profile(&mut self, m: &mut Model, steps: u64) -> Result<GpuProfile> {
        if self.plan.pore_flow.is_some() {
            return Err(Error::InvalidScene(
                "bench --profile does not time the pore network's stage on the GPU; profile the scene with \
                 --backend cpu"
                    .into(),
            ));
        }
        if self.plan.periodic.is_some_and(|c| c.shear.is_some()) {
            // Its steps copy their offsets between passes, which the timed passes do not.
            return Err(Error::InvalidScene(
                "bench --profile does not time a cell sheared by Lees–Edwards images on the GPU; profile the \
                 scene with --backend cpu, or time it with bench"
                    .into(),
            ));
        }
        crate::guard::check_time_step(m)?;
        let mut s = match self.session.take() {
            Some(s) => s,
            None => self.open(m)?,
        };
        let mut stages: Vec<StageTime> = Vec::new();
        let (mut batched_seconds, mut batched_steps, mut dispatches) = (0.0, 0u64, 0u64);
        let (mut submissions, mut timed_reads) = (0, 0);
        let mut done = 0;
        // Batches alternate, each as separate passes and then as a run encodes it, so that
        // both see the machine alike (another process's load comes in bursts).
        while done < steps {
            let per_step = self.step_stages(&s, 0, true).len() + 2;
            let room = ((MAX_PASSES - 4) / per_step).max(1) as u64;
            let first = self.batch.min(room).min(steps - done);
            let guard = done + first == steps;
            for separate in [true, false] {
                // The drift after the first half may allow the second fewer steps.
                let k = if separate { first } else { first.min(self.batch) };
                let before = self.ctx.submissions();
                self.reset_batch_counters(&s, guard);
                let mut work: Vec<(Stage, StageWork)> =
                    (0..k).flat_map(|t| self.step_stages(&s, t, t + 1 == k)).collect();
                work.extend(self.batch_tail(&s, guard));
                if separate {
                    let passes: Vec<&[(Stage, StageWork)]> = work.chunks(1).collect();
                    for ((stage, w), secs) in work.iter().zip(self.time_passes(&passes)?) {
                        let (count, bytes) = w.cost().unwrap_or((0, 0));
                        book(&mut stages, s.kernels.label(*stage), secs, bytes, count);
                    }
                } else {
                    batched_steps += k;
                    batched_seconds += self.time_passes(&[&work[..]])?[0];
                    timed_reads += u64::from(self.timestamp_period().is_some());
                    dispatches += work.iter().filter_map(|(_, w)| w.cost()).map(|(d, _)| d).sum::<u64>();
                }
                drop(work);
                let counters = read::<u32>(&self.ctx, &s.lanes.counters, COUNTERS)?;
                s.steps += k;
                let (drift, speed) = self.check_batch(m, &mut s, &counters, guard)?;
                let t = Instant::now();
                let builds = self.rows.device_builds + self.rows.host_builds;
                self.keep_rows_current(m, &mut s, drift, speed, MAX_BATCH)?;
                if separate && self.rows.device_builds + self.rows.host_builds > builds {
                    book(&mut stages, ROW_BUILDS, t.elapsed().as_secs_f64(), 0, 0);
                }
                if !separate {
                    // As a run submits: the steps, the counters' read, the row builds (not the
                    // timestamps' read).
                    submissions += self.ctx.submissions() - before - timed_reads;
                    timed_reads = 0;
                }
            }
            done += first;
        }
        self.check_device()?;
        self.session = Some(s);
        let clock = match self.timestamp_period() {
            Some(period) => ProfileClock::Timestamps { period },
            None => ProfileClock::Host,
        };
        let per = |x: f64| x / batched_steps.max(1) as f64;
        Ok(GpuProfile {
            particles: m.len(),
            steps,
            stages,
            batched_steps,
            batched_seconds,
            clock,
            dispatches_per_step: per(dispatches as f64),
            submissions_per_step: per(submissions as f64),
            nominal_bandwidth: nominal_bandwidth(&self.ctx.info.name),
        })
    }

    /// Nanoseconds per timestamp tick, when the device has timestamp queries.
    fn timestamp_period(&self) -> Option<f32> {
        self.ctx
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| self.ctx.queue.get_timestamp_period())
    }

    /// Encodes each entry of `passes` as one compute pass, runs them and returns each pass's
    /// seconds: from timestamps written at the pass's start and end, or, without timestamp
    /// queries, from the host's clock around the pass's own submission and wait.
    fn time_passes(&self, passes: &[&[(Stage, StageWork)]]) -> Result<Vec<f64>> {
        let ctx = &self.ctx;
        let Some(period) = self.timestamp_period() else {
            let mut out = Vec::with_capacity(passes.len());
            for work in passes {
                let t = Instant::now();
                let mut enc = ctx.device.create_command_encoder(&Default::default());
                encode(&mut enc, work, None);
                ctx.submit(enc);
                ctx.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Device(e.to_string()))?;
                out.push(t.elapsed().as_secs_f64());
            }
            return Ok(out);
        };
        debug_assert!(passes.len() <= MAX_PASSES);
        let count = 2 * passes.len() as u32;
        let set = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("profile"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let resolved = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("profile timestamps"),
            size: u64::from(count) * 8,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        for (i, work) in passes.iter().enumerate() {
            encode(&mut enc, work, Some((&set, 2 * i as u32)));
        }
        enc.resolve_query_set(&set, 0..count, &resolved, 0);
        ctx.submit(enc);
        let ticks: Vec<u64> = read(ctx, &resolved, count as usize)?;
        Ok(ticks.chunks(2).map(|t| t[1].saturating_sub(t[0]) as f64 * f64::from(period) * 1e-9).collect())
    }
}

/// Encodes `work` as one compute pass, with timestamps at `stamps.1` and the next index.
fn encode(enc: &mut wgpu::CommandEncoder, work: &[(Stage, StageWork)], stamps: Option<(&wgpu::QuerySet, u32)>) {
    let timestamp_writes = stamps.map(|(query_set, k)| wgpu::ComputePassTimestampWrites {
        query_set,
        beginning_of_pass_write_index: Some(k),
        end_of_pass_write_index: Some(k + 1),
    });
    let label = match work {
        [(stage, _)] => stage.name(),
        _ => STEP_BATCH,
    };
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes });
    for (stage, w) in work {
        w.encode(&mut pass, *stage);
    }
}

/// Adds a pass's time and traffic to its stage's line (in first-seen order).
fn book(stages: &mut Vec<StageTime>, name: &'static str, seconds: f64, bytes: u64, dispatches: u64) {
    match stages.iter_mut().find(|s| s.name == name) {
        Some(s) => {
            s.seconds += seconds;
            s.bytes += bytes;
            s.dispatches += dispatches;
        }
        None => stages.push(StageTime { name, seconds, bytes, dispatches }),
    }
}

/// Nominal memory bandwidth (B/s) of data-centre and desktop GPUs by the adapter's name, from
/// the vendors' data sheets; `None` for any other (a software adapter's is the host's memory).
pub fn nominal_bandwidth(adapter: &str) -> Option<f64> {
    let name = adapter.to_lowercase();
    // More specific names first (an "H100 PCIe" is also an "H100").
    const TABLE: [(&str, f64); 14] = [
        ("gh200", 4.0e12),
        ("h200", 4.8e12),
        ("h100 pcie", 2.0e12),
        ("h100", 3.35e12),
        ("a100-sxm4-80gb", 2.039e12),
        ("a100 80gb pcie", 1.935e12),
        ("a100", 1.555e12),
        ("l40s", 8.64e11),
        ("nvidia l4", 3.0e11),
        ("v100", 9.0e11),
        ("rtx 4090", 1.008e12),
        ("rtx 3090", 9.36e11),
        ("mi300x", 5.3e12),
        ("mi250", 3.2e12),
    ];
    TABLE.iter().find(|(key, _)| name.contains(key)).map(|&(_, bw)| bw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_bandwidth_knows_the_h200_and_tells_h100_variants_apart() {
        assert_eq!(nominal_bandwidth("NVIDIA H200"), Some(4.8e12));
        assert_eq!(nominal_bandwidth("NVIDIA H100 PCIe"), Some(2.0e12));
        assert_eq!(nominal_bandwidth("NVIDIA H100 80GB HBM3"), Some(3.35e12));
        assert_eq!(nominal_bandwidth("llvmpipe (LLVM 15.0.6, 256 bits)"), None);
    }
}
