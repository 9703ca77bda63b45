//! Every lane a shader binds, declared once: its WGSL name and type here, and each WGSL file's
//! bindings as an ordered list of lanes and access ([`Bindings`], written next to the file in
//! `shaders.rs`). The `@group(0) @binding(N) var…` lines are generated from the list and put
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
    Buoyancy,
    ParallelBond,
    AppliedLoads,
    Conduction,
    Moisture,
    PoreFlow,
    PoreHeat,
}

const fn lane(home: Home, name: &'static str, ty: &'static str) -> Lane {
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

pub mod buoyancy {
    use super::{lane, Home, Lane};
    /// Level, fluid density, 6π·μ (`Water` in buoyancy.wgsl).
    pub const WATER: Lane = lane(Home::Buoyancy, "water", "Water");
}

pub mod parallel_bond {
    use super::{lane, Home, Lane};
    pub const PARAMS: Lane = lane(Home::ParallelBond, "bp", "BondParams");
    /// The bond rows (CSR) and their ends' states.
    pub const ROW_START: Lane = lane(Home::ParallelBond, "row_start", "array<u32>");
    pub const OTHER: Lane = lane(Home::ParallelBond, "other", "array<u32>");
    pub const BONDS: Lane = lane(Home::ParallelBond, "bonds", "array<Bond>");
}

pub mod applied_loads {
    use super::{lane, Home, Lane};
    pub const FORCE: Lane = lane(Home::AppliedLoads, "applied_force", "array<vec4<f32>>");
    /// A placeholder when no element carries a torque.
    pub const TORQUE: Lane = lane(Home::AppliedLoads, "applied_torque", "array<vec4<f32>>");
}

pub mod conduction {
    use super::{lane, Home, Lane};
    pub const FIELD: Lane = lane(Home::Conduction, "field", "Conduction");
    /// x temperature, y capacity C = m·c, z conductivity k, w source (W).
    pub const THERMAL: Lane = lane(Home::Conduction, "thermal", "array<vec4<f32>>");
    pub const NEXT: Lane = lane(Home::Conduction, "next", "array<f32>");
    pub const CONDUCTANCE: Lane = lane(Home::Conduction, "conductance", "array<f32>");
    pub const MODE: Lane = lane(Home::Conduction, "mode", "array<u32>");
    /// [`MODE`]'s buffer as pore_heat.wgsl names it.
    pub const THERMAL_MODE: Lane = lane(Home::Conduction, "thermal_mode", "array<u32>");
    /// x expansion coefficient α, y radius r0 at T0.
    pub const EXPANSION: Lane = lane(Home::Conduction, "expansion", "array<vec2<f32>>");
    /// Per element, the ledger's booked heat (a compensated pair) at the last field step that
    /// fed it, less what the host had booked at the upload (its own part of the sum starts at
    /// zero).
    pub const FED: Lane = lane(Home::Conduction, "fed", "array<vec2<f32>>");
}

pub mod moisture {
    use super::{lane, Home, Lane};
    pub const FIELD: Lane = lane(Home::Moisture, "field", "Moisture");
    /// x water content ω, y capacity (the element's mass), z diffusivity α_w, w evaporation χ.
    pub const WATER: Lane = lane(Home::Moisture, "water", "array<vec4<f32>>");
    pub const NEXT: Lane = lane(Home::Moisture, "next", "array<f32>");
    pub const CONDUCTANCE: Lane = lane(Home::Moisture, "conductance", "array<f32>");
    pub const MODE: Lane = lane(Home::Moisture, "mode", "array<u32>");
    /// The ambient water content each element dries towards.
    pub const AMBIENT: Lane = lane(Home::Moisture, "ambient", "array<f32>");
    /// The radius r0 where the radius table's factor is 1.
    pub const RADIUS0: Lane = lane(Home::Moisture, "radius0", "array<f32>");
    /// (ω, value) points: the radius table's, then the strength table's.
    pub const TABLES: Lane = lane(Home::Moisture, "tables", "array<vec2<f32>>");
}

pub mod pore_flow {
    use super::{lane, Home, Lane};
    pub const PARAMS: Lane = lane(Home::PoreFlow, "pp", "PoreParams");
    /// The four corners of each tetrahedron, its pore, and its orientation at the build (±1).
    pub const TETS: Lane = lane(Home::PoreFlow, "tets", "array<vec4<u32>>");
    pub const TET_PORE: Lane = lane(Home::PoreFlow, "tet_pore", "array<u32>");
    pub const TET_SIGN: Lane = lane(Home::PoreFlow, "tet_sign", "array<f32>");
    /// Tetrahedra of each pore (CSR).
    pub const PORE_TET_START: Lane = lane(Home::PoreFlow, "pore_tet_start", "array<u32>");
    pub const PORE_TETS: Lane = lane(Home::PoreFlow, "pore_tets", "array<u32>");
    pub const VOLUME: Lane = lane(Home::PoreFlow, "volume", "array<f32>");
    /// The volume at the upload, as pore_geometry measured it.
    pub const VOLUME0: Lane = lane(Home::PoreFlow, "volume0", "array<f32>");
    pub const CENTRE: Lane = lane(Home::PoreFlow, "centre", "array<vec4<f32>>");
    pub const EXCESS: Lane = lane(Home::PoreFlow, "excess", "array<f32>");
    pub const PRESSURE: Lane = lane(Home::PoreFlow, "pressure", "array<f32>");
    /// Per pore: (fixed pressure, volumetric source, 1 when held at the pressure else 0, 0).
    pub const BOUNDARY: Lane = lane(Home::PoreFlow, "boundary", "array<vec4<f32>>");
    /// Per pore: the mass its boundary region supplied since the upload (compensated sum).
    pub const SUPPLIED: Lane = lane(Home::PoreFlow, "supplied", "array<vec2<f32>>");
    /// Throats of each pore (CSR rows, each throat in both of its pores' rows).
    pub const ROW_START: Lane = lane(Home::PoreFlow, "row_start", "array<u32>");
    pub const ROW: Lane = lane(Home::PoreFlow, "row", "array<u32>");
    pub const THROATS: Lane = lane(Home::PoreFlow, "throats", "array<Throat>");
    pub const CONDUCTANCE: Lane = lane(Home::PoreFlow, "conductance", "array<f32>");
    /// The bonds across throats' faces at the build, (i, j), and whether each still holds.
    pub const BOND_EDGES: Lane = lane(Home::PoreFlow, "bond_edges", "array<vec2<u32>>");
    pub const BOND_ALIVE: Lane = lane(Home::PoreFlow, "bond_alive", "array<u32>");
    /// Each element's corners of tetrahedra (CSR), each 4·tet + corner, in tetrahedron order.
    pub const ELEM_START: Lane = lane(Home::PoreFlow, "elem_start", "array<u32>");
    pub const ELEM_CORNERS: Lane = lane(Home::PoreFlow, "elem_corners", "array<u32>");
    /// Each element's position at the network's build, less its origin.
    pub const PORE_BUILT: Lane = lane(Home::PoreFlow, "pore_built", "array<vec4<f32>>");
    /// Per pore: what its excess mass updates rounded away (kg).
    pub const EXCESS_CARRY: Lane = lane(Home::PoreFlow, "excess_carry", "array<f32>");
    /// Per pore: the host's (f64) volume at the upload, rounded to f32.
    pub const VOLUME_HOST: Lane = lane(Home::PoreFlow, "volume_host", "array<f32>");
}

pub mod pore_heat {
    use super::{lane, Home, Lane};
    pub const PARAMS: Lane = lane(Home::PoreHeat, "ph", "PoreHeat");
    /// Per pore: x the excess temperature its region supplies (K), y 1 when its flux region
    /// injects at it, z 1 when its fixed-pressure region holds it there, w its mass less its
    /// excess mass (kg; the mass is w + excess).
    pub const FLUID_BC: Lane = lane(Home::PoreHeat, "fluid_bc", "array<vec4<f32>>");
    pub const WARMTH: Lane = lane(Home::PoreHeat, "warmth", "array<f32>");
    pub const WARMTH_NEXT: Lane = lane(Home::PoreHeat, "warmth_next", "array<f32>");
    /// Per pore: Σ Δm·w its region supplied since the upload (kg·K, compensated), × c_f on
    /// download.
    pub const HEAT_SUPPLIED: Lane = lane(Home::PoreHeat, "heat_supplied", "array<vec2<f32>>");
    /// Per tetrahedron: the exchange conductance of each corner (W/K).
    pub const CORNER_G: Lane = lane(Home::PoreHeat, "corner_g", "array<vec4<f32>>");
    /// Per element: what its exchange updates rounded away (K).
    pub const CARRY: Lane = lane(Home::PoreHeat, "carry", "array<f32>");
    /// Per pore: what its temperature updates rounded away (K), paired with `warmth_next`.
    pub const WARMTH_CARRY: Lane = lane(Home::PoreHeat, "warmth_carry", "array<f32>");
}

#[cfg(test)]
mod tests {
    use super::*;

    const FIRST: &[Binding] = &[uniform(PARAMS), read(ORIGIN)];
    const SECOND: &[Binding] = &[read_write(conduction::THERMAL)];
    const BOTH: Bindings = Bindings(&[FIRST, SECOND]);

    #[test]
    fn bindings_are_numbered_in_order_across_files_and_declared_as_wgsl() {
        assert_eq!(BOTH.number(conduction::THERMAL), Ok(2));
        assert_eq!(
            BOTH.wgsl(),
            "@group(0) @binding(0) var<uniform> params: Params;\n\
             @group(0) @binding(1) var<storage, read> origin: array<vec4<f32>>;\n\
             @group(0) @binding(2) var<storage, read_write> thermal: array<vec4<f32>>;\n"
        );
    }

    #[test]
    fn a_lane_the_shader_does_not_declare_is_an_error_not_a_panic() {
        // Same name and type as the conduction stage's, another home: another lane.
        let e = BOTH.number(moisture::NEXT).unwrap_err().to_string();
        assert!(e.contains("declares no lane `next` (Moisture)") && e.contains("bug"), "{e}");
        let e = BOTH.entries(Some(&[ORIGIN]), &[]).unwrap_err().to_string();
        assert!(e.contains("no buffer given for lane `origin`"), "{e}");
    }
}
