//! The WGSL sources (the only file that names shader paths) and the one way a stage becomes
//! a pipeline: `common.wgsl` and `heat.wgsl` prepended to the stage's file, the plan's choices passed as
//! pipeline-overridable constants, so a switched-off effect is compiled out.

use super::device::GpuContext;
use crate::model::{NormalKind, TangentialKind};
use crate::physics::rolling_resistance::RollingModel;
use crate::plan::StepPlan;

pub const COMMON: &str = include_str!("../../../../shaders/common.wgsl");
pub const HEAT: &str = include_str!("../../../../shaders/heat.wgsl");
pub const NEIGHBOURS: &str = include_str!("../../../../shaders/neighbours.wgsl");
pub const CONTACT_FORCES: &str = include_str!("../../../../shaders/contact_forces.wgsl");
pub const WALL_FORCES: &str = include_str!("../../../../shaders/wall_forces.wgsl");
pub const WALLS: &str = include_str!("../../../../shaders/walls.wgsl");
pub const PARALLEL_BOND: &str = include_str!("../../../../shaders/parallel_bond.wgsl");
pub const INTEGRATE: &str = include_str!("../../../../shaders/integrate.wgsl");
pub const GUARD: &str = include_str!("../../../../shaders/guard.wgsl");
pub const CELL_LIST: &str = include_str!("../../../../shaders/cell_list.wgsl");
pub const SCAN: &str = include_str!("../../../../shaders/scan.wgsl");
pub const ROWS: &str = include_str!("../../../../shaders/rows.wgsl");
pub const BUOYANCY: &str = include_str!("../../../../shaders/buoyancy.wgsl");
pub const APPLIED_LOADS: &str = include_str!("../../../../shaders/applied_loads.wgsl");
/// The conduction stage: the diffusion core it shares with moisture (diffusion.wgsl), then its
/// own file.
pub const CONDUCTION: &str = concat!(
    include_str!("../../../../shaders/diffusion.wgsl"),
    "\n",
    include_str!("../../../../shaders/conduction.wgsl")
);
pub const ROLLING_RESISTANCE: &str = include_str!("../../../../shaders/rolling_resistance.wgsl");
/// The moisture stage: the diffusion core it shares (diffusion.wgsl), then its own file.
pub const MOISTURE: &str = concat!(
    include_str!("../../../../shaders/diffusion.wgsl"),
    "\n",
    include_str!("../../../../shaders/moisture.wgsl")
);
pub const PORE_FLOW: &str = include_str!("../../../../shaders/pore_flow.wgsl");
/// The pore fluid's temperature: pore_flow.wgsl (its bindings and helpers), then its own file.
pub const PORE_HEAT: &str = concat!(
    include_str!("../../../../shaders/pore_flow.wgsl"),
    "\n",
    include_str!("../../../../shaders/pore_heat.wgsl")
);

/// Every stage by name, for validation without a device.
pub const STAGES: [(&str, &str); 17] = [
    ("neighbours", NEIGHBOURS),
    ("cell_list", CELL_LIST),
    ("scan", SCAN),
    ("rows", ROWS),
    ("contact_forces", CONTACT_FORCES),
    ("wall_forces", WALL_FORCES),
    ("walls", WALLS),
    ("parallel_bond", PARALLEL_BOND),
    ("rolling_resistance", ROLLING_RESISTANCE),
    ("integrate", INTEGRATE),
    ("guard", GUARD),
    ("applied_loads", APPLIED_LOADS),
    ("buoyancy", BUOYANCY),
    ("conduction", CONDUCTION),
    ("moisture", MOISTURE),
    ("pore_flow", PORE_FLOW),
    ("pore_heat", PORE_HEAT),
];

/// A stage's full source: the shared prelude (common.wgsl, then the heat ledger's slots and
/// sum, which the dissipating stages book into) and the stage's own file.
pub fn source(stage: &str) -> String {
    format!("{COMMON}\n{HEAT}\n{stage}")
}

/// The plan's choices as the overrides of common.wgsl.
pub fn constants(plan: &StepPlan) -> Vec<(&'static str, f64)> {
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    vec![
        ("NORMAL_HERTZ", flag(plan.normal == NormalKind::Hertz)),
        ("MINDLIN", flag(plan.tangential.is_mindlin())),
        ("TANGENTIAL_DASHPOT", flag(plan.tangential == TangentialKind::MindlinDamped)),
        ("DASHPOT", flag(plan.dashpot)),
        ("ROTATION", flag(plan.rotation)),
        ("VISCOUS", flag(plan.damping > 0.0)),
        ("LOCAL", flag(plan.local_damping > 0.0)),
        ("ROLLING_SPRING", flag(plan.rolling.is_some_and(|r| r.model == RollingModel::Epsd))),
    ]
}

/// A compute pipeline for `entry` of a stage, its bind group layout derived from the shader.
/// Compiled once per device for each (stage, entry, constants): a script whose plan changes
/// between runs (a platen's servo set, a material added) builds new plans, not new pipelines,
/// and a driver's compile costs more than a small scene's run.
pub fn pipeline(
    device: &GpuContext,
    label: &str,
    stage: &str,
    entry: &str,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    let key = PipelineKey {
        label: label.to_string(),
        stage: stage.to_string(),
        entry: entry.to_string(),
        constants: constants.iter().map(|&(k, v)| (k.to_string(), v.to_bits())).collect(),
    };
    let mut cache = device.pipelines.lock().unwrap_or_else(|p| p.into_inner());
    cache
        .entry(key)
        .or_insert_with(|| {
            let module = device.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source(stage).into()),
            });
            device.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    zero_initialize_workgroup_memory: true,
                },
                cache: None,
            })
        })
        .clone()
}

/// What makes two pipelines the same ([`pipeline`]).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct PipelineKey {
    label: String,
    stage: String,
    entry: String,
    constants: Vec<(String, u64)>,
}

/// A pipeline bound to its buffers, and how many workgroups one dispatch needs.
pub struct Kernel {
    pub pipeline: wgpu::ComputePipeline,
    pub bind_group: wgpu::BindGroup,
    pub groups: (u32, u32),
    /// Bytes of the buffers bound: what one dispatch may read and write at most (`bench
    /// --profile` divides it by the stage's time).
    pub bytes: u64,
}

impl Kernel {
    /// Binds `buffers` to bindings 0, 1, 2, … of group 0.
    pub fn bind(
        device: &wgpu::Device,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer],
        groups: (u32, u32),
    ) -> Self {
        let numbered: Vec<(u32, &wgpu::Buffer)> = buffers.iter().enumerate().map(|(k, b)| (k as u32, *b)).collect();
        Self::bind_at(device, pipeline, &numbered, groups)
    }

    /// Binds each buffer to its binding of group 0 (for an entry point that uses only some of
    /// its file's bindings).
    pub fn bind_at(
        device: &wgpu::Device,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[(u32, &wgpu::Buffer)],
        groups: (u32, u32),
    ) -> Self {
        let layout = pipeline.get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .map(|&(k, b)| wgpu::BindGroupEntry { binding: k, resource: b.as_entire_binding() })
            .collect();
        let bind_group =
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &entries });
        let bytes = buffers.iter().map(|(_, b)| b.size()).sum();
        Kernel { pipeline: pipeline.clone(), bind_group, groups, bytes }
    }

    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
    }
}

/// Dispatches, and bytes their kernels bind, of a field stage's run: the `sub` kernels once
/// per sub-step, `substeps` of them, the `once` kernels once (`bench --profile`).
pub fn cost<'k>(
    substeps: u32,
    sub: impl Iterator<Item = &'k Kernel>,
    once: impl Iterator<Item = &'k Kernel>,
) -> (u64, u64) {
    let tally = |ks: &mut dyn Iterator<Item = &'k Kernel>| ks.fold((0u64, 0u64), |(c, b), k| (c + 1, b + k.bytes));
    let (n, (sc, sb), (oc, ob)) = (u64::from(substeps), tally(&mut { sub }), tally(&mut { once }));
    (n * sc + oc, n * sb + ob)
}

/// Workgroups of 64 covering `n` items, as a 2-D grid when one row of 65,535 is not enough.
pub fn groups_for(n: usize) -> (u32, u32) {
    grid(n.div_ceil(64))
}

/// `total` workgroups (at least one) as a 2-D grid when one row of 65,535 is not enough.
pub fn grid(total: usize) -> (u32, u32) {
    let total = total.max(1);
    if total <= 65_535 {
        (total as u32, 1)
    } else {
        (65_535, total.div_ceil(65_535) as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_stage_parses_and_validates() {
        for (name, stage) in STAGES {
            naga_parse(&source(stage)).unwrap_or_else(|e| panic!("{name}.wgsl: {e}"));
        }
    }

    fn naga_parse(src: &str) -> Result<(), String> {
        // wgpu re-exports naga; parse and validate as wgpu would.
        let module = wgpu::naga::front::wgsl::parse_str(src).map_err(|e| e.emit_to_string(src))?;
        let mut v = wgpu::naga::valid::Validator::new(
            wgpu::naga::valid::ValidationFlags::all(),
            wgpu::naga::valid::Capabilities::all(),
        );
        v.validate(&module).map_err(|e| e.emit_to_string(src))?;
        Ok(())
    }

    #[test]
    fn large_counts_use_a_second_grid_dimension() {
        assert_eq!(groups_for(1), (1, 1));
        assert_eq!(groups_for(64 * 65_535), (65_535, 1));
        let (x, y) = groups_for(50_000_000);
        assert!(x as usize * y as usize * 64 >= 50_000_000 && y == 12);
    }
}
