//! Every lane a shader binds, declared once: its WGSL name and type — the core's here, an
//! effect's in its `gpu.rs` (`mod wgsl`, home [`Home::Effect`]) — and each WGSL file's bindings
//! as an ordered list of lanes and access ([`Bindings`], written next to the file: the core's
//! in `shaders.rs`, an effect's as its `gpu.rs`'s `SHADER`). The `@group(0) @binding(N) var…` lines are generated from the list and put
//! before the file's source, and kernels bind their buffers by the same list, so a binding's
//! number comes from one place: its position.
//!
//! A lane's buffer is found in the lanes it lives in (its [`Home`]): the core's
//! [`DeviceLanes`](super::buffers::DeviceLanes), a slab's [`SlabLanes`](super::buffers::SlabLanes),
//! or a field stage's own lanes, each a [`Holder`].

use crate::error::{GpuError, Result};

/// One lane as WGSL declares it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lane {
    /// Where its buffer lives; two stages' lanes of the same name are different lanes.
    pub home: Home,
    pub name: &'static str,
    /// A struct of common.wgsl or of its stage's file for a uniform, an array for storage.
    pub ty: &'static str,
}

/// The lanes a buffer lives in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Home {
    Core,
    Slab,
    ScanLevel,
    /// An optional effect's own lanes, by the effect's name (declared in its `gpu.rs`).
    Effect(&'static str),
}

pub const fn lane(home: Home, name: &'static str, ty: &'static str) -> Lane {
    Lane { home, name, ty }
}

/// How a shader may use a binding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    Uniform,
    Read,
    ReadWrite,
}

/// A lane and how one file uses it (the same lane is read in one file and written in another).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Binding {
    pub lane: Lane,
    pub access: Access,
}

pub const fn uniform(lane: Lane) -> Binding {
    Binding { lane, access: Access::Uniform }
}

pub const fn read(lane: Lane) -> Binding {
    Binding { lane, access: Access::Read }
}

pub const fn read_write(lane: Lane) -> Binding {
    Binding { lane, access: Access::ReadWrite }
}

/// A shader's bindings: its files' lists, numbered 0, 1, 2, … in order across them (a stage
/// compiled from two files binds the first file's, then the second's).
#[derive(Debug, Clone, Copy)]
pub struct Bindings(pub &'static [&'static [Binding]]);

impl Bindings {
    /// Each binding with its number.
    pub fn numbered(&self) -> impl Iterator<Item = (u32, &'static Binding)> {
        (0u32..).zip(self.0.iter().copied().flatten())
    }

    /// The binding number of `lane`; an error when the shader declares no such lane.
    pub fn number(&self, lane: Lane) -> Result<u32> {
        match self.numbered().find(|(_, b)| b.lane == lane) {
            Some((k, _)) => Ok(k),
            None => {
                Err(GpuError::Binding(format!("the shader declares no lane `{}` ({:?})", lane.name, lane.home)).into())
            }
        }
    }

    /// The WGSL declarations, one line a binding.
    pub fn wgsl(&self) -> String {
        self.numbered()
            .map(|(k, b)| {
                let space = match b.access {
                    Access::Uniform => "uniform",
                    Access::Read => "storage, read",
                    Access::ReadWrite => "storage, read_write",
                };
                format!("@group(0) @binding({k}) var<{space}> {}: {};\n", b.lane.name, b.lane.ty)
            })
            .collect()
    }

    /// The buffers of `lanes` (all the shader's when `None`) by binding number, each found in
    /// the one of `holders` it lives in.
    pub fn entries<'a>(
        &self,
        lanes: Option<&[Lane]>,
        holders: &[&'a dyn Holder],
    ) -> Result<Vec<(u32, &'a wgpu::Buffer)>> {
        let numbered: Vec<(u32, Lane)> = match lanes {
            None => self.numbered().map(|(k, b)| (k, b.lane)).collect(),
            Some(lanes) => lanes.iter().map(|&l| self.number(l).map(|k| (k, l))).collect::<Result<_>>()?,
        };
        numbered
            .into_iter()
            .map(|(k, lane)| match holders.iter().find_map(|h| h.buffer(lane)) {
                Some(b) => Ok((k, b)),
                None => {
                    Err(GpuError::Binding(format!("no buffer given for lane `{}` ({:?})", lane.name, lane.home)).into())
                }
            })
            .collect()
    }
}

/// Lanes that hold buffers: the buffer of each lane whose home they are.
pub trait Holder {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer>;
}

/// A lone buffer (a stage's uniform) holds its one lane.
impl Holder for (Lane, &wgpu::Buffer) {
    fn buffer(&self, lane: Lane) -> Option<&wgpu::Buffer> {
        (lane == self.0).then_some(self.1)
    }
}

// The core's lanes (`DeviceLanes`): per particle unless said otherwise.

/// Scene constants (`Params` in common.wgsl).
pub const PARAMS: Lane = lane(Home::Core, "params", "Params");
/// Position at the upload (f32) and radius in w: kernels move only `disp`.
pub const ORIGIN: Lane = lane(Home::Core, "origin", "array<vec4<f32>>");
/// Displacement since the upload.
pub const DISP: Lane = lane(Home::Core, "disp", "array<vec4<f32>>");
pub const VEL: Lane = lane(Home::Core, "vel", "array<vec4<f32>>");
/// Mass and c/m of the viscous damping.
pub const BODY: Lane = lane(Home::Core, "body", "array<vec4<f32>>");
/// Material and fixities (the KILLED bit: in no row).
pub const KIND: Lane = lane(Home::Core, "kind", "array<u32>");
/// Each element's clump (`u32::MAX`: none); one word while the model has no clumps.
pub const CLUMP_OF: Lane = lane(Home::Core, "clump_of", "array<u32>");
pub const FORCE: Lane = lane(Home::Core, "force", "array<vec4<f32>>");
pub const ANG_VEL: Lane = lane(Home::Core, "ang_vel", "array<vec4<f32>>");
pub const TORQUE: Lane = lane(Home::Core, "torque", "array<vec4<f32>>");
/// The rotation since the upload (rad): θ += ω·dt with the half-step ω, as disp moves
/// (rotation on).
pub const ANGLE: Lane = lane(Home::Core, "angle", "array<vec4<f32>>");
/// Displacement at the rows' build.
pub const BUILT: Lane = lane(Home::Core, "built", "array<vec4<f32>>");
pub const ROW_LEN: Lane = lane(Home::Core, "row_len", "array<u32>");
/// The cell list: bucket counts, bucket starts (the scan's first level), particles in bucket
/// order.
pub const BUCKET_COUNT: Lane = lane(Home::Core, "bucket_count", "array<atomic<u32>>");
pub const CELL_START: Lane = lane(Home::Core, "cell_start", "array<u32>");
pub const CELL_ITEMS: Lane = lane(Home::Core, "cell_items", "array<u32>");
/// The scan's levels in place (the buffer of [`CELL_START`], as scan.wgsl names it).
pub const SCAN_DATA: Lane = lane(Home::Core, "data", "array<u32>");
/// Per wall.
pub const WALLS: Lane = lane(Home::Core, "walls", "array<Wall>");
/// Contact constants per pair of materials, and per material and wall.
pub const PAIRS: Lane = lane(Home::Core, "pairs", "array<Pair>");
pub const WALL_PAIRS: Lane = lane(Home::Core, "wall_pairs", "array<Pair>");
/// Wall loads per workgroup and wall, summed by the walls stage.
pub const PARTIALS: Lane = lane(Home::Core, "partials", "array<vec4<f32>>");
/// The partials summed 64 workgroups at a time, in scenes of more than 256 workgroups.
pub const FOLDED: Lane = lane(Home::Core, "folded", "array<vec4<f32>>");
/// The C_* slots of common.wgsl.
pub const COUNTERS: Lane = lane(Home::Core, "counters", "array<atomic<u32>>");
/// Bond breakages of the batch.
pub const EVENTS: Lane = lane(Home::Core, "events", "array<vec4<u32>>");
/// The heat ledger (heat_ledger.wgsl).
pub const HEAT: Lane = lane(Home::Core, "heat", "array<vec2<f32>>");

// A slab's lanes (`SlabLanes`): per row entry (rank by rank), or per particle and wall.

/// The slab's first particle and count (`Slab` in common.wgsl).
pub const SLAB: Lane = lane(Home::Slab, "slab", "Slab");
pub const OTHER: Lane = lane(Home::Slab, "other", "array<u32>");
pub const STATE: Lane = lane(Home::Slab, "state", "array<vec4<f32>>");
pub const WALL_STATE: Lane = lane(Home::Slab, "wall_state", "array<vec4<f32>>");
/// The dashpot force of the last step (a placeholder without DASHPOT).
pub const DASHPOT: Lane = lane(Home::Slab, "dashpot", "array<f32>");
/// epsd's rolling springs, per entry and per particle and wall (placeholders without
/// ROLLING_SPRING).
pub const ROLLING: Lane = lane(Home::Slab, "rolling", "array<vec4<f32>>");
pub const WALL_ROLLING: Lane = lane(Home::Slab, "wall_rolling", "array<vec4<f32>>");

/// One level of the cell list's prefix scan (`ScanLevel` in scan.wgsl).
pub const SCAN_LEVEL: Lane = lane(Home::ScanLevel, "level", "ScanLevel");

#[cfg(test)]
mod tests {
    use super::*;

    /// An effect's lane, and one of the same name and type in another effect.
    const THERMAL: Lane = lane(Home::Effect("conduction"), "thermal", "array<vec4<f32>>");
    const NEXT: Lane = lane(Home::Effect("moisture"), "next", "array<f32>");
    const FIRST: &[Binding] = &[uniform(PARAMS), read(ORIGIN)];
    const SECOND: &[Binding] = &[read_write(THERMAL)];
    const BOTH: Bindings = Bindings(&[FIRST, SECOND]);

    #[test]
    fn bindings_are_numbered_in_order_across_files_and_declared_as_wgsl() {
        assert_eq!(BOTH.number(THERMAL), Ok(2));
        assert_eq!(
            BOTH.wgsl(),
            "@group(0) @binding(0) var<uniform> params: Params;\n\
             @group(0) @binding(1) var<storage, read> origin: array<vec4<f32>>;\n\
             @group(0) @binding(2) var<storage, read_write> thermal: array<vec4<f32>>;\n"
        );
    }

    #[test]
    fn a_lane_the_shader_does_not_declare_is_an_error_not_a_panic() {
        // Same name and type as a lane of the conduction stage's, another home: another lane.
        let e = BOTH.number(NEXT).unwrap_err().to_string();
        assert!(e.contains("declares no lane `next` (Effect(\"moisture\"))") && e.contains("bug"), "{e}");
        let e = BOTH.entries(Some(&[ORIGIN]), &[]).unwrap_err().to_string();
        assert!(e.contains("no buffer given for lane `origin`"), "{e}");
    }
}
