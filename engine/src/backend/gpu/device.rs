//! Choosing a compute device: `--backend cpu|gpu|auto`. The choice itself ([`pick`]) is a
//! pure function of the adapters' descriptions, tested without a GPU; [`select`] asks wgpu
//! for the adapters and opens the device with the adapter's own limits (lavapipe allows
//! 128 MiB per storage binding, a hardware GPU far more).

use crate::error::{Error, GpuError, Result};
use std::sync::Arc;

/// What the user asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackendChoice {
    /// A GPU worth measuring (hardware; software too with [`AUTO_SOFTWARE`]`=1`) when there
    /// is one, else the CPU backend; a host then times its scene on both and steps on the
    /// faster ([`crate::backend::speed_test`]).
    Auto,
    /// The native CPU backend (f64).
    Cpu,
    /// Any wgpu adapter, a software one (Mesa lavapipe/llvmpipe) included.
    Gpu,
}

impl std::str::FromStr for BackendChoice {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "auto" => Ok(BackendChoice::Auto),
            "cpu" => Ok(BackendChoice::Cpu),
            "gpu" => Ok(BackendChoice::Gpu),
            _ => Err(Error::unknown("backend", s, &["auto", "cpu", "gpu"])),
        }
    }
}

/// The environment variable that lets `auto` measure a software adapter too (`=1`): for tests,
/// and for a machine whose software Vulkan may be fast. Without it a machine with only
/// lavapipe/llvmpipe runs on the CPU without paying a speed test on every run.
pub const AUTO_SOFTWARE: &str = "MATDEM_AUTO_SOFTWARE";

/// An open device and what it is.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// The limits the device was opened with (the adapter's own).
    pub limits: wgpu::Limits,
    /// Command buffers submitted through [`submit`](Self::submit) (`bench --profile`).
    submitted: std::sync::atomic::AtomicU64,
    /// Pipelines compiled on this device ([`super::shaders::pipeline`]).
    pub(crate) pipelines: std::sync::Mutex<std::collections::HashMap<PipelineKey, wgpu::ComputePipeline>>,
}

/// What makes two pipelines the same (`shaders::pipeline`), the key of a device's cache.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct PipelineKey {
    pub label: String,
    /// The whole source, the generated binding declarations with it.
    pub source: String,
    pub entry: String,
    /// The pipeline constants, by name, as bits.
    pub constants: Vec<(String, u64)>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GpuContext({})", self.describe())
    }
}

impl GpuContext {
    /// "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, software)"-style description.
    pub fn describe(&self) -> String {
        describe(&summary(&self.info))
    }

    /// Submits the encoder's commands, counting the submission.
    pub fn submit(&self, enc: wgpu::CommandEncoder) {
        self.submitted.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.queue.submit([enc.finish()]);
    }

    /// Submissions so far.
    pub fn submissions(&self) -> u64 {
        self.submitted.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Whether the adapter is a software rasteriser (lavapipe/llvmpipe): correct, not fast.
    pub fn is_software(&self) -> bool {
        summary(&self.info).software
    }
}

/// What [`select`] settled on.
pub enum Compute {
    Cpu { reason: String },
    Gpu(Arc<GpuContext>),
}

/// The facts about an adapter that the choice depends on.
#[derive(Debug, Clone, PartialEq)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    /// 0 discrete, 1 integrated, 2 virtual, 3 other, 4 software (CPU).
    pub rank: u8,
    pub software: bool,
    pub vulkan: bool,
}

pub fn summary(info: &wgpu::AdapterInfo) -> AdapterSummary {
    let rank = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    };
    let lower = info.name.to_lowercase();
    // Mesa's software drivers report DeviceType::Cpu; the names catch a driver that does not.
    let software =
        rank == 4 || lower.contains("llvmpipe") || lower.contains("lavapipe") || lower.contains("swiftshader");
    AdapterSummary {
        name: info.name.clone(),
        backend: format!("{:?}", info.backend),
        rank: if software { 4 } else { rank },
        software,
        vulkan: info.backend == wgpu::Backend::Vulkan,
    }
}

pub fn describe(a: &AdapterSummary) -> String {
    let kind = if a.software { "software" } else { "hardware" };
    format!("{} ({}, {kind})", a.name, a.backend)
}

/// Which adapter (an index into `adapters`) to open, or why the CPU backend runs instead.
/// Hardware before software, discrete before integrated, Vulkan before GL; `Auto` never
/// takes a software adapter (it is several times slower than the native CPU backend).
pub fn pick(adapters: &[AdapterSummary], choice: BackendChoice) -> std::result::Result<usize, String> {
    if choice == BackendChoice::Cpu {
        return Err("requested with --backend cpu".into());
    }
    let best = (0..adapters.len()).min_by_key(|&k| (adapters[k].rank, !adapters[k].vulkan, k));
    let Some(k) = best else {
        return Err("no GPU adapter found (no GPU driver, and no Mesa lavapipe/llvmpipe: install \
                    mesa-vulkan-drivers for a software Vulkan device)"
            .into());
    };
    if choice == BackendChoice::Auto && adapters[k].software {
        return Err(format!(
            "only a software adapter, {}, which is slower than the CPU backend; use --backend gpu to run on it",
            describe(&adapters[k])
        ));
    }
    Ok(k)
}

/// Opens the device `choice` asks for. `Gpu` without a usable adapter is an error;
/// `Auto` falls back to the CPU backend and says why, and passes over a software adapter
/// unless [`AUTO_SOFTWARE`] is `1`.
pub fn select(choice: BackendChoice) -> Result<Compute> {
    if choice == BackendChoice::Cpu {
        return Ok(Compute::Cpu { reason: "requested with --backend cpu".into() });
    }
    let desc = wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN | wgpu::Backends::GL | wgpu::Backends::METAL | wgpu::Backends::DX12,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    }
    .with_env();
    let instance = wgpu::Instance::new(desc);
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
    let summaries: Vec<AdapterSummary> = adapters.iter().map(|a| summary(&a.get_info())).collect();
    let software_ok = choice == BackendChoice::Auto && std::env::var(AUTO_SOFTWARE).is_ok_and(|v| v == "1");
    let k = match pick(&summaries, if software_ok { BackendChoice::Gpu } else { choice }) {
        Ok(k) => k,
        Err(reason) if choice == BackendChoice::Auto => return Ok(Compute::Cpu { reason }),
        Err(reason) => return Err(Error::Gpu(GpuError::NoAdapter { reason })),
    };
    let adapter = &adapters[k];
    let limits = adapter.limits();
    // Timestamp queries where the adapter has them, for `bench --profile`.
    let request = wgpu::DeviceDescriptor {
        label: Some("matdem"),
        required_limits: limits.clone(),
        required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
        ..Default::default()
    };
    match pollster::block_on(adapter.request_device(&request)) {
        Ok((device, queue)) => Ok(Compute::Gpu(Arc::new(GpuContext {
            device,
            queue,
            info: adapter.get_info(),
            limits,
            submitted: Default::default(),
            pipelines: Default::default(),
        }))),
        Err(e) => {
            let reason = format!("opening {} failed: {e}", describe(&summaries[k]));
            if choice == BackendChoice::Auto {
                Ok(Compute::Cpu { reason })
            } else {
                Err(Error::Gpu(GpuError::NoAdapter { reason }))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adapter(name: &str, rank: u8, vulkan: bool) -> AdapterSummary {
        AdapterSummary {
            name: name.into(),
            backend: if vulkan { "Vulkan" } else { "Gl" }.into(),
            rank,
            software: rank == 4,
            vulkan,
        }
    }

    #[test]
    fn auto_prefers_a_discrete_gpu_and_vulkan() {
        let a = [
            adapter("llvmpipe", 4, true),
            adapter("igpu", 1, true),
            adapter("H100", 0, false),
            adapter("H100", 0, true),
        ];
        assert_eq!(pick(&a, BackendChoice::Auto), Ok(3));
        assert_eq!(pick(&a, BackendChoice::Gpu), Ok(3));
    }

    #[test]
    fn auto_refuses_a_software_adapter_but_gpu_takes_it() {
        let a = [adapter("llvmpipe (LLVM 15)", 4, false), adapter("llvmpipe (LLVM 15)", 4, true)];
        let why = pick(&a, BackendChoice::Auto).unwrap_err();
        assert!(why.contains("software adapter") && why.contains("--backend gpu"), "{why}");
        assert_eq!(pick(&a, BackendChoice::Gpu), Ok(1), "Vulkan before GL");
    }

    #[test]
    fn no_adapter_says_what_to_install() {
        let why = pick(&[], BackendChoice::Gpu).unwrap_err();
        assert!(why.contains("mesa-vulkan-drivers"), "{why}");
        assert!(pick(&[adapter("H100", 0, true)], BackendChoice::Cpu).is_err());
    }

    #[test]
    fn backend_keywords_parse_and_a_typo_gets_a_suggestion() {
        assert_eq!("gpu".parse::<BackendChoice>().unwrap(), BackendChoice::Gpu);
        let e = "gpuu".parse::<BackendChoice>().unwrap_err().to_string();
        assert!(e.contains("did you mean `gpu`"), "{e}");
    }
}
