//! The core's WGSL sources, each with its bindings (an effect's are in its `gpu.rs`), and the
//! one way a stage becomes a pipeline: `common.wgsl` and `heat_ledger.wgsl`, then the stage's binding
//! declarations (generated from its [`Bindings`]), then the stage's file; the plan's choices
//! passed as pipeline-overridable constants, so a switched-off effect is compiled out.

use super::bindings::{self as b, *};
use super::device::{GpuContext, PipelineKey};
use crate::effects::rolling_resistance::physics::RollingModel;
use crate::error::Result;
use crate::plan::StepPlan;

pub const COMMON: &str = include_str!("../../../../shaders/common.wgsl");
pub const HEAT_LEDGER: &str = include_str!("../../../../shaders/heat_ledger.wgsl");

/// A stage's WGSL: its source (one file, or two compiled together) and its bindings.
#[derive(Debug)]
pub struct Shader {
    pub name: &'static str,
    pub source: &'static str,
    pub bindings: Bindings,
}

pub const NEIGHBOURS: Shader = Shader {
    name: "neighbours",
    source: concat!(
        include_str!("../../../../shaders/periodic_image.wgsl"),
        "\n",
        include_str!("../../../../shaders/neighbours.wgsl")
    ),
    bindings: Bindings(&[&[uniform(PARAMS), read(DISP), read(BUILT), read(VEL), read_write(COUNTERS)]]),
};

pub const CELL_LIST: Shader = Shader {
    name: "cell_list",
    source: concat!(
        include_str!("../../../../shaders/periodic_image.wgsl"),
        "\n",
        include_str!("../../../../shaders/cell_list.wgsl")
    ),
    bindings: Bindings(&[&[
        uniform(PARAMS),
        read(ORIGIN),
        read(DISP),
        read_write(BUCKET_COUNT),
        read(CELL_START),
        read_write(CELL_ITEMS),
    ]]),
};

pub const SCAN: Shader = Shader {
    name: "scan",
    source: include_str!("../../../../shaders/scan.wgsl"),
    bindings: Bindings(&[&[read_write(SCAN_DATA), uniform(SCAN_LEVEL)]]),
};

pub const ROWS: Shader = Shader {
    name: "rows",
    source: concat!(
        include_str!("../../../../shaders/periodic_image.wgsl"),
        "\n",
        include_str!("../../../../shaders/rows.wgsl")
    ),
    bindings: Bindings(&[&[
        uniform(PARAMS),
        read(ORIGIN),
        read(DISP),
        read(CELL_START),
        read(CELL_ITEMS),
        read_write(ROW_LEN),
        read_write(OTHER),
        read_write(STATE),
        read_write(BUILT),
        read_write(COUNTERS),
        uniform(SLAB),
        read_write(DASHPOT),
        read_write(ROLLING),
        read(KIND),
        read(CLUMP_OF),
    ]]),
};

pub const CONTACT_FORCES: Shader = Shader {
    name: "contact_forces",
    source: concat!(
        include_str!("../../../../shaders/periodic_image.wgsl"),
        "\n",
        include_str!("../../../../shaders/contact_forces.wgsl")
    ),
    bindings: Bindings(&[&[
        uniform(PARAMS),
        read(ORIGIN),
        read(DISP),
        read(VEL),
        read(BODY),
        read(KIND),
        read(ROW_LEN),
        read(OTHER),
        read_write(STATE),
        read(PAIRS),
        read_write(FORCE),
        read(ANG_VEL),
        read_write(TORQUE),
        read_write(COUNTERS),
        read_write(EVENTS),
        uniform(SLAB),
        read_write(DASHPOT),
        read_write(HEAT),
    ]]),
};

/// The wall pass's bindings. The particle lanes integration writes are writable here, so the
/// pass with integration in it (below) binds the same list and integration's own after it.
const WALL_PASS_BINDINGS: &[Binding] = &[
    uniform(PARAMS),
    read(ORIGIN),
    read_write(DISP),
    read_write(VEL),
    read(BODY),
    read(KIND),
    read(b::WALLS),
    read(WALL_PAIRS),
    read_write(WALL_STATE),
    read_write(FORCE),
    read_write(ANG_VEL),
    read_write(TORQUE),
    read_write(PARTIALS),
    uniform(SLAB),
    read_write(HEAT),
];

pub const WALL_FORCES: Shader = Shader {
    name: "wall_forces",
    source: include_str!("../../../../shaders/wall_forces.wgsl"),
    bindings: Bindings(&[WALL_PASS_BINDINGS]),
};

/// The wall pass with integration after it in one kernel (plans with walls and no force stage):
/// wall_forces.wgsl and integrate.wgsl, then the entry point that calls both.
pub const WALL_FORCES_INTEGRATE: Shader = Shader {
    name: "wall_forces_integrate",
    source: concat!(
        include_str!("../../../../shaders/wall_forces.wgsl"),
        "\n",
        include_str!("../../../../shaders/integrate.wgsl"),
        "\n",
        include_str!("../../../../shaders/wall_forces_integrate.wgsl")
    ),
    bindings: Bindings(&[WALL_PASS_BINDINGS, &[read_write(COUNTERS), read_write(ANGLE)]]),
};

pub const WALLS: Shader = Shader {
    name: "walls",
    source: include_str!("../../../../shaders/walls.wgsl"),
    bindings: Bindings(&[&[uniform(PARAMS), read_write(b::WALLS), read(PARTIALS), read_write(FOLDED)]]),
};

pub const INTEGRATE: Shader = Shader {
    name: "integrate",
    source: include_str!("../../../../shaders/integrate.wgsl"),
    bindings: Bindings(&[&[
        uniform(PARAMS),
        read(ORIGIN),
        read(BODY),
        read(KIND),
        read(FORCE),
        read_write(VEL),
        read_write(DISP),
        read(TORQUE),
        read_write(ANG_VEL),
        read_write(COUNTERS),
        read_write(HEAT),
        read_write(ANGLE),
    ]]),
};

pub const GUARD: Shader = Shader {
    name: "guard",
    source: concat!(
        include_str!("../../../../shaders/periodic_image.wgsl"),
        "\n",
        include_str!("../../../../shaders/guard.wgsl")
    ),
    bindings: Bindings(&[&[
        uniform(PARAMS),
        read(ORIGIN),
        read(DISP),
        read(VEL),
        read(FORCE),
        read(ROW_LEN),
        read(OTHER),
        read(b::WALLS),
        read_write(COUNTERS),
        uniform(SLAB),
        read(BODY),
        read(KIND),
        read(PAIRS),
        read(WALL_PAIRS),
        read(STATE),
    ]]),
};

/// A stage's full source: the shared prelude (common.wgsl, then the heat ledger's slots and
/// sum, which the dissipating stages book into), the stage's binding declarations, and the
/// stage's own source.
pub fn source(stage: &Shader) -> String {
    format!("{COMMON}\n{HEAT_LEDGER}\n{}{}", stage.bindings.wgsl(), stage.source)
}

/// The plan's choices as the overrides of common.wgsl.
pub fn constants(plan: &StepPlan) -> Vec<(&'static str, f64)> {
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    // The contact laws' own switches, as each law gives them.
    let laws = plan.normal.gpu_switches().into_iter().chain(plan.tangential.gpu_switches());
    let laws = laws.map(|(name, on)| (name, flag(on)));
    laws.chain([
        ("DASHPOT", flag(plan.dashpot)),
        ("ROTATION", flag(plan.rotation)),
        ("VISCOUS", flag(plan.damping > 0.0)),
        ("LOCAL", flag(plan.local_damping > 0.0)),
        ("ROLLING_SPRING", flag(plan.rolling.is_some_and(|r| r.model == RollingModel::Epsd))),
        ("PLANAR", flag(plan.planar.is_some())),
        ("CLUMPS", flag(plan.clumps.is_some())),
        ("PERIODIC", flag(plan.periodic.is_some())),
        ("SHEAR", flag(plan.periodic.is_some_and(|c| c.shear.is_some()))),
    ])
    .collect()
}

/// A compute pipeline for `entry` of a stage, its bind group layout derived from the shader.
/// Compiled once per device for each (source, entry, constants): a script whose plan changes
/// between runs (a platen's servo set, a material added) builds new plans, not new pipelines,
/// and a driver's compile costs more than a small scene's run.
pub fn pipeline(
    device: &GpuContext,
    label: &str,
    stage: &'static Shader,
    entry: &str,
    constants: &[(&str, f64)],
) -> Pipeline {
    let source = source(stage);
    let key = PipelineKey {
        label: label.to_string(),
        // The whole source, the generated declarations with it.
        source: source.clone(),
        entry: entry.to_string(),
        constants: constants.iter().map(|&(k, v)| (k.to_string(), v.to_bits())).collect(),
    };
    let mut cache = device.pipelines.lock().unwrap_or_else(|p| p.into_inner());
    let compute = cache
        .entry(key)
        .or_insert_with(|| {
            let module = device.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
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
        .clone();
    Pipeline { compute, stage }
}

/// A compute pipeline and the stage it was built from, whose bindings its kernels bind.
#[derive(Clone)]
pub struct Pipeline {
    pub compute: wgpu::ComputePipeline,
    pub stage: &'static Shader,
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
    /// Binds every binding of the pipeline's stage to its lane's buffer, found in `holders`.
    pub fn bind(
        device: &wgpu::Device,
        pipeline: &Pipeline,
        holders: &[&dyn Holder],
        groups: (u32, u32),
    ) -> Result<Self> {
        let entries = pipeline.stage.bindings.entries(None, holders)?;
        Ok(Self::bind_entries(device, pipeline, &entries, groups))
    }

    /// Binds `lanes` alone: for an entry point that uses only some of its stage's bindings (its
    /// layout, derived from the shader, holds only those).
    pub fn bind_lanes(
        device: &wgpu::Device,
        pipeline: &Pipeline,
        lanes: &[Lane],
        holders: &[&dyn Holder],
        groups: (u32, u32),
    ) -> Result<Self> {
        let entries = pipeline.stage.bindings.entries(Some(lanes), holders)?;
        Ok(Self::bind_entries(device, pipeline, &entries, groups))
    }

    fn bind_entries(
        device: &wgpu::Device,
        pipeline: &Pipeline,
        buffers: &[(u32, &wgpu::Buffer)],
        groups: (u32, u32),
    ) -> Self {
        let layout = pipeline.compute.get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .map(|&(k, b)| wgpu::BindGroupEntry { binding: k, resource: b.as_entire_binding() })
            .collect();
        let bind_group =
            device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &entries });
        let bytes = buffers.iter().map(|(_, b)| b.size()).sum();
        Kernel { pipeline: pipeline.compute.clone(), bind_group, groups, bytes }
    }

    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
    }
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
    fn every_contact_law_switch_is_an_override_of_common_wgsl() {
        use crate::model::{NormalKind, TangentialKind};
        let names = NormalKind::ALL.iter().flat_map(|k| k.gpu_switches().map(|(n, _)| n));
        let names: Vec<&str> =
            names.chain(TangentialKind::ALL.iter().flat_map(|k| k.gpu_switches().map(|(n, _)| n))).collect();
        for name in names {
            assert!(COMMON.contains(&format!("override {name}: bool")), "common.wgsl has no override `{name}`");
        }
        // Each law is told apart from the others by its switches.
        let normal: Vec<_> = NormalKind::ALL.map(|k| k.gpu_switches()).to_vec();
        assert!(normal.iter().enumerate().all(|(a, x)| normal[a + 1..].iter().all(|y| x != y)));
        let tangential: Vec<_> = TangentialKind::ALL.map(|k| k.gpu_switches()).to_vec();
        assert!(tangential.iter().enumerate().all(|(a, x)| tangential[a + 1..].iter().all(|y| x != y)));
    }

    #[test]
    fn every_stage_parses_and_validates() {
        for stage in super::super::all_shaders() {
            naga_parse(&source(stage)).unwrap_or_else(|e| panic!("{}: {e}", stage.name));
        }
    }

    #[test]
    fn bindings_are_declared_only_by_the_lists() {
        for stage in super::super::all_shaders() {
            assert!(!stage.source.contains("@binding"), "{}: declare a binding in its list instead", stage.name);
        }
        assert!(!COMMON.contains("@binding") && !HEAT_LEDGER.contains("@binding"));
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
