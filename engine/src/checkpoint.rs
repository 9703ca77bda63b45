//! Checkpoints: a model saved to bytes and read back, so a later run continues it bit for bit
//! (MatDEM's build → cut/assign → test workflow across scripts, and `--resume`).
//!
//! Layout, all integers little-endian:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `MDEMCKPT` |
//! | 4 | format version ([`FORMAT_VERSION`]) |
//! | 8 | payload length n |
//! | n | payload: postcard encoding of (writer's engine version, [`Model`], host annex, the model's parallel bonds, fields, provenance, strength shares, sections, body work) |
//! | 4 | CRC-32 (IEEE) of everything before it |
//!
//! The model is saved whole, derived rows included: positions, half-step velocities, forces,
//! per-pair shear and bond state, wall contact states, walls with their servo state, groups,
//! materials, settings, clock (time, step, dt), breakages, the heat ledger, the parallel
//! bonds with their forces and moments (after the annex, from format 3: a format-2 file, which
//! ends at the annex, loads with none) and the fields — heat and water settings, the thermal
//! lanes (temperature, capacity, …) when heat is on — after the bonds, from format 4 (an older
//! file loads with heat off and no water), then the bonds' strength shares (format 6) and the
//! optional stages' sections — rolling resistance with epsd's springs, pore flow with its
//! network and fluid, moisture with its water lanes (since 2026-12-07 in the effects' state
//! sections, one per effect that keeps a state in the model, by its name), the pore fluid's heat (its temperatures,
//! thermal properties, permeability factors, region temperatures and totals), the applied loads
//! with their work account, the rotation angles (a file without these sections loads with no
//! loads and every angle at zero) — from format 7, and
//! the energy account's body work with the body fields it last saw (format 8: an older file loads
//! with no body work and the fields it holds as the ones seen, `BodyWork::from_fields`). The engine
//! keeps no other state between steps and draws no random numbers while stepping (the box
//! builder's generator is spent once the box is built), so a loaded model steps exactly as
//! the saved one would have. The annex is the host's own data (its record tables), opaque here.
//!
//! The engine does no file I/O: hosts write the bytes (atomically) and read them back.

use crate::body_potential::{BodyFields, BodyWork};
use crate::effects::applied_loads::lanes::AppliedLoads;
use crate::effects::buoyancy::WaterTable;
use crate::effects::clumps::lanes::Clumps;
use crate::effects::conduction::lanes::{ThermalLanes, FIXED, FREE, INSULATED};
use crate::effects::conduction::HeatSettings;
use crate::effects::confining_pressure::state::ConfiningState;
use crate::effects::confining_pressure::Confinement;
use crate::effects::moisture::lanes::MoistureLanes;
use crate::effects::moisture::state::MoistureState;
use crate::effects::moisture::MoistureSettings;
use crate::effects::parallel_bond::lanes::ParallelBonds;
use crate::effects::periodic::state::PeriodicState;
use crate::effects::pore_flow::coupling::PoreSettings;
use crate::effects::pore_flow::flow::{PoreBoundary, PoreFlow};
use crate::effects::pore_flow::{Fluid, FluidHeat};
use crate::effects::rolling_resistance::physics::RollingResistance;
use crate::effects::{EffectState, Fit};
use crate::element_values::MAX_MATERIALS;
use crate::model::Model;
use crate::physics::Vec3;
use crate::provenance::Provenance;
use crate::state::check_row_starts;
use crate::walls::{WallMotion, WallShape, MAX_WALLS};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The first bytes of every checkpoint.
pub const MAGIC: &[u8; 8] = b"MDEMCKPT";
/// Bumped whenever the payload's layout changes; files of a version this build does not know
/// are refused, not misread.
pub const FORMAT_VERSION: u32 = 8;
/// The oldest format this build still reads: 2 lacks the parallel bonds (a model without them),
/// 2 and 3 the fields (heat and water settings, thermal lanes: a model with heat off, no water),
/// 2 to 4 the materials' provenance (their values then have none recorded), 2 to 5 the bonds'
/// strength shares (every bond whole), 2 to 6 the optional stages' sections (rolling
/// resistance and pore flow off), 2 to 7 the body work (none booked).
pub const OLDEST_VERSION: u32 = 2;
const HEADER: usize = 8 + 4 + 8;
const TRAILER: usize = 4;

/// Why bytes are not a checkpoint this build can load. Messages say what is wrong and what to
/// do; the host adds the file name.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CheckpointError {
    #[error(
        "not a matdem-rs checkpoint (it does not begin with the `MDEMCKPT` marker): give a file written by \
         `d.save` (name.mdem)"
    )]
    NotACheckpoint,
    #[error(
        "checkpoint format version {found} is not supported (this build reads versions {OLDEST_VERSION} to \
         {supported}): load it with the matdem-rs that wrote it, or re-create it with this one"
    )]
    UnsupportedVersion { found: u32, supported: u32 },
    #[error(
        "the checkpoint is truncated ({found} of {expected} bytes): the write was cut short or the copy is \
         incomplete; use an intact copy or save the model again"
    )]
    Truncated { expected: u64, found: u64 },
    #[error(
        "the checkpoint is corrupt ({reason}): the file was changed or damaged after it was written; use an intact \
         copy or save the model again"
    )]
    Corrupt { reason: String },
    #[error(
        "the checkpoint was written by matdem-engine {writer} and its model does not fit this build ({reason}): \
         load it with that version, or re-create it with this one"
    )]
    Incompatible { writer: String, reason: String },
}

/// A loaded checkpoint: the model and the host's annex.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    pub model: Model,
    pub annex: Vec<u8>,
}

#[derive(Serialize)]
struct PayloadOut<'a> {
    writer: &'a str,
    model: &'a Model,
    annex: &'a [u8],
    parallel_bonds: &'a ParallelBonds,
    fields: FieldsOut<'a>,
    provenance: Vec<&'a Provenance>,
    weakened: Vec<(u32, u16)>,
    sections: Vec<Section>,
    body_work: &'a BodyWork,
}

/// The fields' settings and lanes (format 4), saved after the parallel bonds.
#[derive(Serialize)]
struct FieldsOut<'a> {
    heat: &'a HeatSettings,
    water: &'a WaterTable,
    thermal: &'a ThermalLanes,
}

#[derive(Deserialize, Default)]
struct Fields {
    heat: HeatSettings,
    water: WaterTable,
    thermal: ThermalLanes,
}

/// Format 7 on: the optional stages' settings and state, one tagged section each, after the
/// bonds' strength shares. A stage added later appends a variant (postcard tags variants by
/// their index), so the payload's layout need not change again for it.
#[derive(Serialize, Deserialize)]
enum Section {
    /// Rolling resistance's setting and epsd's springs (by row entry, then by element × wall;
    /// empty for cdt or before the first step).
    Rolling { setting: RollingResistance, rows: Vec<Vec3>, walls: Vec<Vec3> },
    /// Pore flow: the scene's fluid and boundaries and, while it is on, the network as last
    /// built (it is rebuilt only after a drift, so it cannot be derived from the positions)
    /// with its fluid.
    PoreFlow { settings: PoreSettings, flow: Option<Box<PoreFlow>> },
    /// Moisture's settings and water lanes, as files written before the effects' states
    /// (2026-12-07) carry them; read only: moisture is an [`Section::Effect`] now.
    Moisture { settings: MoistureSettings, lanes: MoistureLanes },
    /// What pore flow gained after its first section (written after it, whenever it is):
    /// the fluid's thermal properties and per-material permeability factors, the boundary
    /// regions' temperatures (the scene's list), and while pore flow is on the pores'
    /// temperatures and each region's booked mass and heat. A file without it loads with
    /// water's thermal properties, no factors, no region temperatures and zero totals.
    PoreHeat { settings: PoreHeatSettings, flow: Option<PoreHeatState> },
    /// The applied loads: each element's force and torque and the work account's offsets (empty
    /// once released) and its booked work. A file without it loads with no loads.
    AppliedLoads { lanes: AppliedLoads },
    /// The rotation lanes' accumulated angles (with rotation on). A file without it loads with
    /// every angle at zero.
    RotationAngle { angle: Vec<Vec3> },
    /// The confining pressure on a cylindrical sample (its pressure, axis, platens and cells),
    /// as files written before the effects' states (2026-12-07) carry it; read only: it is an
    /// [`Section::Effect`] now.
    Confinement { settings: Confinement },
    /// A 2D model's plate. A file without it loads 3D.
    Planar { setting: crate::planar::setting::Planar },
    /// The clumps' bodies, members and offsets. A file without it loads with none.
    Clumps { clumps: Clumps },
    /// The periodic cell, as files written before the effects' states (2026-12-07) carry it;
    /// read only: it is an [`Section::Effect`] now.
    Periodic { cell: crate::effects::periodic::Periodic },
    /// The state of an effect that keeps one in the model (`effects::EffectState`), by the
    /// effect's name, in the effect's own encoding: a new effect needs no variant here. A file
    /// without it loads with the effect as a new model has it.
    Effect { name: String, state: Vec<u8> },
}

/// The pore fluid's settings that [`Section::PoreHeat`] carries.
#[derive(Serialize, Deserialize)]
struct PoreHeatSettings {
    heat: FluidHeat,
    permeability: BTreeMap<String, f64>,
    temperatures: Vec<Option<f64>>,
}

impl PoreHeatSettings {
    fn of(fluid: &Fluid, boundaries: &[PoreBoundary]) -> Self {
        PoreHeatSettings {
            heat: fluid.heat,
            permeability: fluid.permeability.clone(),
            temperatures: boundaries.iter().map(|b| b.temperature).collect(),
        }
    }

    fn apply(self, fluid: &mut Fluid, boundaries: &mut [PoreBoundary]) -> Result<(), String> {
        if self.temperatures.len() != boundaries.len() {
            return Err("pore boundary temperatures do not match the boundary regions".into());
        }
        fluid.heat = self.heat;
        fluid.permeability = self.permeability;
        for (b, t) in boundaries.iter_mut().zip(self.temperatures) {
            b.temperature = t;
        }
        Ok(())
    }
}

/// The pore fluid's state that [`Section::PoreHeat`] carries.
#[derive(Serialize, Deserialize)]
struct PoreHeatState {
    settings: PoreHeatSettings,
    temperature: Vec<f64>,
    reference: f64,
    region_mass: Vec<f64>,
    region_heat: Vec<f64>,
}

impl Section {
    fn of(m: &Model) -> Vec<Section> {
        let mut out = Vec::new();
        if let Some(setting) = m.settings.rolling {
            out.push(Section::Rolling { setting, rows: m.contacts.rolling.clone(), walls: m.wall_rolling.clone() });
        }
        if m.settings.pores != PoreSettings::default() || m.pores.is_some() {
            out.push(Section::PoreFlow { settings: m.settings.pores.clone(), flow: m.pores.clone() });
            let s = &m.settings.pores;
            let flow = m.pores.as_ref().map(|f| PoreHeatState {
                settings: PoreHeatSettings::of(&f.fluid, &f.boundaries),
                temperature: f.temperature.clone(),
                reference: f.reference,
                region_mass: f.region_mass.clone(),
                region_heat: f.region_heat.clone(),
            });
            out.push(Section::PoreHeat { settings: PoreHeatSettings::of(&s.fluid, &s.boundaries), flow });
        }
        let applied = &m.particles.applied;
        if applied.allocated(m.len()) || applied.booked != 0.0 {
            out.push(Section::AppliedLoads { lanes: applied.clone() });
        }
        if let Some(r) = &m.particles.rotation {
            out.push(Section::RotationAngle { angle: r.angle.clone() });
        }
        if let Some(setting) = m.settings.planar {
            out.push(Section::Planar { setting });
        }
        if !m.clumps.is_empty() {
            out.push(Section::Clumps { clumps: m.clumps.clone() });
        }
        // NOTE: as `encode` says, every type in the model serialises.
        let effects = m.effects.sections().expect("the effects' states always serialise");
        out.extend(effects.into_iter().map(|(name, state)| Section::Effect { name, state }));
        out
    }

    fn apply(self, m: &mut Model) -> Result<(), String> {
        match self {
            Section::Rolling { setting, rows, walls } => {
                let n = m.len();
                if !(rows.is_empty() || rows.len() == m.contacts.other.len()) {
                    return Err("rolling springs do not match the neighbour rows".into());
                }
                if !(walls.is_empty() || walls.len() == n * m.walls.len()) {
                    return Err("rolling springs do not match particles × walls".into());
                }
                m.settings.rolling = Some(setting);
                m.contacts.rolling = rows;
                m.wall_rolling = walls;
            }
            Section::PoreFlow { settings, mut flow } => {
                if let Some(f) = &mut flow {
                    // Totals a file before the pore heat section lacks start at zero.
                    f.region_mass.resize(f.boundaries.len(), 0.0);
                    f.region_heat.resize(f.boundaries.len(), 0.0);
                    f.consistent(m.len())?;
                }
                m.settings.pores = settings;
                m.pores = flow;
            }
            Section::Moisture { settings, lanes } => {
                let state = MoistureState { settings, lanes };
                state.check(&fit(m))?;
                m.effects.moisture = state;
            }
            Section::Effect { name, state } => {
                // Out of the model while the model is read (a refusal refuses the whole file).
                let mut effects = std::mem::take(&mut m.effects);
                effects.load(&name, &state, &fit(m))?;
                m.effects = effects;
            }
            Section::AppliedLoads { lanes } => {
                if !lanes.consistent(m.len()) {
                    return Err("applied loads do not match the particles, or are not finite".into());
                }
                m.particles.applied = lanes;
            }
            Section::Confinement { settings } => {
                let state = ConfiningState { confinement: Some(settings) };
                state.check(&fit(m))?;
                m.effects.confining_pressure = state;
            }
            Section::Planar { setting } => {
                let t = setting.thickness;
                if !(t.is_finite() && t > 0.0) {
                    return Err("the 2D model's thickness is not a finite length > 0".into());
                }
                let held = crate::planar::setting::HELD;
                if m.particles.pos.iter().zip(&m.particles.fixed).any(|(x, f)| x.y != 0.0 || f & held != held) {
                    return Err("a 2D model's element lies off the plane y = 0 or is free to leave it".into());
                }
                m.settings.planar = Some(setting);
            }
            Section::Clumps { clumps } => {
                check_clumps(&clumps, &m.particles.fixed)?;
                m.clumps = clumps;
            }
            Section::Periodic { cell } => {
                let state = PeriodicState { cell: Some(cell) };
                state.check(&fit(m))?;
                m.effects.periodic = state;
            }
            Section::RotationAngle { angle } => {
                let n = m.len();
                let Some(r) = m.particles.rotation.as_mut() else {
                    return Err("rotation angles without the rotation lanes".into());
                };
                if angle.len() != n || !angle.iter().all(|a| a.iter().all(|c| c.is_finite())) {
                    return Err("rotation angles do not match the particles, or are not finite".into());
                }
                r.angle = angle;
            }
            Section::PoreHeat { settings, flow } => {
                let s = &mut m.settings.pores;
                settings.apply(&mut s.fluid, &mut s.boundaries)?;
                match (flow, m.pores.as_mut()) {
                    (Some(state), Some(f)) => {
                        state.settings.apply(&mut f.fluid, &mut f.boundaries)?;
                        let pores = f.network.pore_count();
                        if !(state.temperature.is_empty() || state.temperature.len() == pores)
                            || state.region_mass.len() != f.boundaries.len()
                            || state.region_heat.len() != f.boundaries.len()
                        {
                            return Err("pore temperatures do not match the pore network".into());
                        }
                        f.temperature = state.temperature;
                        f.reference = state.reference;
                        f.region_mass = state.region_mass;
                        f.region_heat = state.region_heat;
                    }
                    (None, None) => {}
                    _ => return Err("the pore heat section does not match the pore flow section".into()),
                }
            }
        }
        Ok(())
    }
}

/// What a checkpoint holds, as read from any format this build knows.
struct PayloadIn {
    writer: String,
    model: Model,
    annex: Vec<u8>,
    parallel_bonds: ParallelBonds,
    fields: Fields,
    /// Each material's provenance, in material order (format 5; kept out of `Material`'s own
    /// serialisation so material files and older checkpoints stay readable).
    provenance: Vec<Provenance>,
    /// Format 6: the weakened bonds (joints) as (row entry, `PairState::weakened`), the rest
    /// whole. Kept out of the pair state's own encoding so formats 2 to 5 still read.
    weakened: Vec<(u32, u16)>,
    sections: Vec<Section>,
    /// Format 8: the energy account's body work and the fields it last saw (`None`: an older
    /// file, derived from the loaded fields in [`decode`]). Not a section: the account is not
    /// an optional stage, and a build that does not know it must refuse the file by its
    /// version rather than load a model whose account would not close.
    body_work: Option<BodyWork>,
}

impl PayloadIn {
    /// Reads the payload of a `version` file. Each format appended items to the one before
    /// it, and postcard encodes a struct as its fields one after the other, so the items are
    /// taken in order and those a format lacks keep their defaults.
    fn read(payload: &[u8], version: u32) -> Result<Self, postcard::Error> {
        fn take<'a, T: Deserialize<'a>>(rest: &mut &'a [u8]) -> Result<T, postcard::Error> {
            let (value, tail) = postcard::take_from_bytes(rest)?;
            *rest = tail;
            Ok(value)
        }
        fn since<'a, T: Deserialize<'a> + Default>(
            rest: &mut &'a [u8],
            version: u32,
            first: u32,
        ) -> Result<T, postcard::Error> {
            if version >= first {
                take(rest)
            } else {
                Ok(T::default())
            }
        }
        let rest = &mut &payload[..];
        let p = PayloadIn {
            writer: take(rest)?,
            model: take(rest)?,
            annex: take(rest)?,
            parallel_bonds: since(rest, version, 3)?,
            fields: since(rest, version, 4)?,
            provenance: since(rest, version, 5)?,
            weakened: since(rest, version, 6)?,
            sections: since(rest, version, 7)?,
            body_work: if version >= 8 { Some(take(rest)?) } else { None },
        };
        if !rest.is_empty() {
            return Err(postcard::Error::DeserializeBadEncoding);
        }
        Ok(p)
    }
}

/// The engine version stamped into checkpoints.
pub const WRITER: &str = env!("CARGO_PKG_VERSION");

/// Encodes `model` and the host's `annex` as checkpoint bytes.
pub fn encode(model: &Model, annex: &[u8]) -> Vec<u8> {
    encode_sections(model, annex, Some)
}

/// [`encode`] with the sections as `older` writes them, `None` for one it leaves out (a file
/// as an older build wrote it, for tests).
fn encode_sections(model: &Model, annex: &[u8], older: impl Fn(Section) -> Option<Section>) -> Vec<u8> {
    let fields =
        FieldsOut { heat: &model.settings.heat, water: &model.settings.water, thermal: &model.particles.thermal };
    let provenance = model.materials.iter().map(|m| &m.provenance).collect();
    let weakened = (model.contacts.state.iter().enumerate())
        .filter(|(_, s)| s.bonded && s.weakened != 0)
        .map(|(e, s)| (e as u32, s.weakened))
        .collect();
    let out = PayloadOut {
        writer: WRITER,
        model,
        annex,
        parallel_bonds: &model.parallel_bonds,
        fields,
        provenance,
        weakened,
        sections: Section::of(model).into_iter().filter_map(older).collect(),
        body_work: &model.body_work,
    };
    let payload = postcard::to_stdvec(&out)
        // NOTE: every type in the model serialises (no maps with non-string keys, no
        // unsupported serde features), so a failure here is an engine bug, not a user error.
        .expect("the model always serialises");
    let mut out = Vec::with_capacity(HEADER + payload.len() + TRAILER);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// Decodes checkpoint bytes, refusing anything that is not an intact checkpoint of this
/// format version.
pub fn decode(bytes: &[u8]) -> Result<Checkpoint, CheckpointError> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err(CheckpointError::NotACheckpoint);
    }
    if bytes.len() < HEADER {
        return Err(CheckpointError::Truncated { expected: (HEADER + TRAILER) as u64, found: bytes.len() as u64 });
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if !(OLDEST_VERSION..=FORMAT_VERSION).contains(&version) {
        return Err(CheckpointError::UnsupportedVersion { found: version, supported: FORMAT_VERSION });
    }
    let len = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
    let expected = (HEADER as u64).saturating_add(len).saturating_add(TRAILER as u64);
    let found = bytes.len() as u64;
    if found < expected {
        return Err(CheckpointError::Truncated { expected, found });
    }
    if found > expected {
        return Err(CheckpointError::Corrupt {
            reason: format!("{} unexpected byte(s) after its end", found - expected),
        });
    }
    let body = HEADER + len as usize;
    let stored = u32::from_le_bytes(bytes[body..].try_into().expect("4 bytes"));
    let computed = crc32fast::hash(&bytes[..body]);
    if stored != computed {
        return Err(CheckpointError::Corrupt {
            reason: format!("checksum {computed:08x} does not match the stored {stored:08x}"),
        });
    }
    let payload = &bytes[HEADER..body];
    // A payload that does not decode or a model that does not hold together: written by this
    // engine version in this format, the file was altered after it was written (its checksum
    // recomputed: damaged in a way the CRC missed, or forged); by another, it may be a layout
    // this build misreads.
    let refuse = |writer: String, reason: String| match writer == WRITER && version == FORMAT_VERSION {
        true => CheckpointError::Corrupt { reason },
        false => CheckpointError::Incompatible { writer, reason },
    };
    // A forged length prefix (a Vec of 2⁶⁰ elements) costs no allocation: serde preallocates
    // at most 1 MiB of a sequence (`size_hint::cautious`), and postcard gives no size hint
    // beyond the bytes left, so the read fails at the payload's end instead.
    let mut p = PayloadIn::read(payload, version).map_err(|e| {
        // The writer's version leads the payload, so it can usually be read even when the
        // model that follows cannot.
        let writer = postcard::take_from_bytes::<String>(payload).map(|(w, _)| w).unwrap_or_default();
        let writer = if writer.is_empty() { "?".into() } else { writer };
        refuse(writer, format!("its payload does not decode: {e}"))
    })?;
    p.model.parallel_bonds = p.parallel_bonds;
    p.model.settings.heat = p.fields.heat;
    p.model.settings.water = p.fields.water;
    p.model.particles.thermal = p.fields.thermal;
    // The angles travel in a section of their own (a file without it: every element at zero).
    let n = p.model.len();
    if let Some(r) = p.model.particles.rotation.as_mut() {
        r.angle = vec![Vec3::zeros(); n];
    }
    // After the fields, whose water table an older file's derived account takes as seen.
    p.model.body_work = p.body_work.unwrap_or_else(|| BodyWork::from_fields(BodyFields::of(&p.model)));
    for (m, prov) in p.model.materials.iter_mut().zip(p.provenance) {
        m.provenance = prov;
    }
    let writer = p.writer;
    let refuse = |reason: String| refuse(writer.clone(), reason);
    let state = &mut p.model.contacts.state;
    for &(e, w) in &p.weakened {
        match state.get_mut(e as usize) {
            Some(s) if s.bonded => s.weakened = w,
            _ => return Err(refuse(format!("a bond strength share refers to row entry {e}, not a bond"))),
        }
    }
    check_consistent(&p.model).map_err(refuse)?;
    for section in p.sections {
        section.apply(&mut p.model).map_err(refuse)?;
    }
    check_substeps(&p.model).map_err(refuse)?;
    Ok(Checkpoint { model: p.model, annex: p.annex })
}

/// Sub-step counts within what a setter takes (after the sections, which carry two of them).
fn check_substeps(m: &Model) -> Result<(), String> {
    use crate::physics::timestep::MAX_SUBSTEPS;
    let s = &m.settings;
    let mut counts = vec![
        ("heat sub-steps", s.heat.substeps),
        ("moisture sub-steps", m.effects.moisture.settings.substeps),
        ("the pore fluid's max_substeps", s.pores.fluid.max_substeps),
    ];
    if let Some(f) = &m.pores {
        counts.push(("the pore fluid's max_substeps", f.fluid.max_substeps));
    }
    match counts.into_iter().find(|&(_, n)| n == 0 || n > MAX_SUBSTEPS) {
        Some((what, n)) => Err(format!("{what} = {n}, outside 1 to {MAX_SUBSTEPS}")),
        None => Ok(()),
    }
}

/// What must hold before the model is stepped: a well-formed but inconsistent payload (a
/// damaged writer, or a file forged with its checksum recomputed: a shared package may ship
/// one) would otherwise index out of bounds, or hand `f64::clamp` bounds it panics on. Every
/// lane length, every index and every cross-reference the steppers and the hosts read with a
/// loaded value is checked here, and the values the steppers would panic on; the sections'
/// lanes in [`Section::apply`]. The error names the first thing that is wrong.
fn check_consistent(m: &Model) -> Result<(), String> {
    check_particles(m)?;
    check_walls(m)?;
    check_neighbour_rows(m)?;
    let pb = &m.parallel_bonds;
    if !(pb.row_start.is_empty() && pb.other.is_empty() && pb.state.is_empty()) {
        check_symmetric_rows("parallel bond rows", &pb.row_start, &pb.other, pb.state.len(), m.len())?;
    }
    m.groups.check(m.len())
}

/// The particle lanes, the materials they name and the radii.
fn check_particles(m: &Model) -> Result<(), String> {
    let p = &m.particles;
    let n = p.len();
    let lanes = [
        ("radii", p.radius.len()),
        ("velocities", p.vel.len()),
        ("masses", p.mass.len()),
        ("forces", p.force.len()),
        ("materials", p.material.len()),
        ("fixities", p.fixed.len()),
        ("origins", p.origin.len()),
    ];
    if let Some((what, l)) = lanes.iter().find(|(_, l)| *l != n) {
        return Err(format!("particle lanes of different lengths: {l} {what} for {n} positions"));
    }
    // A ledger lane is allocated (one entry per particle) or absent (empty) until a plan books it.
    if p.heat.lanes().iter().any(|l| !l.is_empty() && l.len() != n) {
        return Err("heat ledger does not match the particles".into());
    }
    if !p.thermal.consistent(n) {
        return Err("thermal lanes do not match the particles".into());
    }
    if let Some((i, k)) = p.thermal.mode.iter().enumerate().find(|(_, &k)| ![FREE, FIXED, INSULATED].contains(&k)) {
        return Err(format!("thermal mode {k} of particle {i} is none of free (0), fixed (1), insulated (2)"));
    }
    if let Some(rot) = &p.rotation {
        if rot.ang_vel.len() != n || rot.torque.len() != n || rot.angle.len() != n {
            return Err("rotation lanes do not match the particles".into());
        }
    }
    let materials = m.materials.len();
    // The plan's table of pair constants is materials²: bounded as `add_material` bounds it.
    if materials > MAX_MATERIALS {
        return Err(format!("{materials} materials, more than the {MAX_MATERIALS} a scene may have"));
    }
    if let Some((i, &k)) = p.material.iter().enumerate().find(|(_, &k)| k as usize >= materials) {
        return Err(format!("particle {i} refers to material {k}, and the model has {materials}"));
    }
    // Contacts, cell lists and the submerged cap read the radius; thermal expansion makes it
    // from radius0.
    check_radii("radius", &p.radius)?;
    check_radii("radius at the reference temperature", &p.thermal.radius0)
}

/// Radii (of the particles, or at a reference) are finite numbers > 0.
/// What an effect's state read from a checkpoint must fit: the model's elements and walls.
fn fit(m: &Model) -> Fit<'_> {
    Fit { elements: m.len(), walls: m.walls.iter().map(|w| w.name.as_str()).collect() }
}

fn check_radii(what: &str, radii: &[f64]) -> Result<(), String> {
    match radii.iter().enumerate().find(|(_, r)| !(r.is_finite() && **r > 0.0)) {
        Some((i, r)) => Err(format!("particle {i} has {what} {r} m: a radius is a finite number > 0")),
        None => Ok(()),
    }
}

/// The walls, their contact states and what a step clamps with their values.
fn check_walls(m: &Model) -> Result<(), String> {
    let (n, nw) = (m.len(), m.walls.len());
    // Wall loads are summed in arrays of MAX_WALLS, and wall masks are bytes.
    if nw > MAX_WALLS {
        return Err(format!("{nw} walls, more than the {MAX_WALLS} a scene may have"));
    }
    if m.wall_contacts.len() != n * nw {
        let states = m.wall_contacts.len();
        return Err(format!("wall contact states: {states} for {n} particles × {nw} walls"));
    }
    for w in &m.walls {
        // `Wall::advance` clamps a servo's speed to ±max_speed, and a cone's distance clamps
        // along its profile: bounds as the constructors and setters leave them.
        if let WallMotion::Servo { max_speed, .. } = w.motion {
            if !(max_speed.is_finite() && max_speed >= 0.0) {
                return Err(format!("wall `{}`: servo max_speed {max_speed} m/s is not a finite number ≥ 0", w.name));
            }
        }
        if let WallShape::Cone { half_angle, radius, rod_length, .. } = w.shape {
            let ok = half_angle > 0.0
                && half_angle < std::f64::consts::FRAC_PI_2
                && radius.is_finite()
                && radius > 0.0
                && rod_length.is_finite()
                && rod_length >= 0.0;
            if !ok {
                return Err(format!(
                    "cone `{}`: half-angle {half_angle} rad, radius {radius} m, rod length {rod_length} m (a cone needs \
                     an angle in (0, π/2), a finite radius > 0 and a rod length ≥ 0)",
                    w.name
                ));
            }
        }
    }
    let c = &m.contacts;
    // Each mask bit is a wall the wall pass indexes.
    if let Some((i, &bits)) = c.wall_near.iter().enumerate().find(|(_, &b)| nw < u8::BITS as usize && b >> nw != 0) {
        return Err(format!("wall mask of particle {i} ({bits:#010b}) names a wall beyond the model's {nw}"));
    }
    Ok(())
}

/// `n` rows of ids in CSR form in which every pair appears in both rows: as many states as
/// entries, ids below `n`, none the row's own, each row increasing, each entry mirrored in its
/// partner's row. The error names `what` and the first entry that is wrong.
fn check_symmetric_rows(what: &str, start: &[u32], other: &[u32], states: usize, n: usize) -> Result<(), String> {
    check_row_starts(what, start, n, other.len())?;
    if states != other.len() {
        return Err(format!("{what}: {states} states for {} entries", other.len()));
    }
    let row = |i: usize| &other[start[i] as usize..start[i + 1] as usize];
    for i in 0..n {
        for (k, &j) in row(i).iter().enumerate() {
            let at = start[i] as usize + k;
            if j as usize >= n {
                return Err(format!("{what}: entry {at} of particle {i} is particle {j}, and the rows cover {n}"));
            }
            if j as usize == i {
                return Err(format!("{what}: entry {at} of particle {i} is the particle itself"));
            }
            if k > 0 && row(i)[k - 1] >= j {
                return Err(format!(
                    "{what}: particle {i}'s row lists {j} after {} (ids must increase)",
                    row(i)[k - 1]
                ));
            }
            if row(j as usize).binary_search(&(i as u32)).is_err() {
                return Err(format!("{what}: particle {i}'s row lists {j}, and {j}'s row does not list {i}"));
            }
        }
    }
    Ok(())
}

/// The neighbour rows (absent until first built) and, once derived, their pair ids: the
/// contact passes slice the rows by `row_start` and `pair_start` and index the pair records by
/// `pair`, so all three must be what [`crate::neighbours::rebuild`] makes of the rows.
fn check_neighbour_rows(m: &Model) -> Result<(), String> {
    let c = &m.contacts;
    let (n, e) = (m.len(), c.other.len());
    // A skin that is NaN would never let the rows be rebuilt, whatever moved.
    if !(c.skin.is_finite() && c.skin >= 0.0) {
        return Err(format!("neighbour skin {} m is not a finite number ≥ 0", c.skin));
    }
    if c.row_start.is_empty() {
        let derived = [e, c.state.len(), c.pair.len(), c.pair_start.len()];
        if derived.iter().any(|&l| l > 0) {
            return Err(format!(
                "neighbour rows not built, yet {e} entries, {} states, {} pair ids and {} pair row starts",
                c.state.len(),
                c.pair.len(),
                c.pair_start.len()
            ));
        }
        return Ok(());
    }
    // Rows built before particles were added cover the first ones only, and are stale: the
    // next step, observer or surgery rebuilds them for all (`Model::add_particle`).
    let rows = c.row_start.len() - 1;
    if rows > n || (rows < n && !c.stale) {
        let starts = c.row_start.len();
        return Err(format!("neighbour rows: {starts} row starts for {n} particles (need {})", n + 1));
    }
    check_symmetric_rows("neighbour rows", &c.row_start, &c.other, c.state.len(), rows)?;
    if c.pair.is_empty() && c.pair_start.is_empty() {
        // Not derived yet: the next step rebuilds the rows, reading only what is checked above.
        return Ok(());
    }
    if !c.has_pair_ids() {
        let (ids, starts) = (c.pair.len(), c.pair_start.len());
        return Err(format!("pair ids: {ids} for {e} row entries, {starts} pair row starts for {rows} rows"));
    }
    // Each pair is in both rows (checked above), so the entries come two by two.
    check_row_starts("pair rows", &c.pair_start, rows, e / 2)?;
    for i in 0..rows {
        let row = c.row(i);
        // The pairs particle i owns are those with its higher-id neighbours: its row's tail.
        let owned = c.pair_start[i + 1] - c.pair_start[i];
        let higher = c.other[row.clone()].iter().filter(|&&j| j as usize > i).count();
        if owned as usize != higher {
            return Err(format!("pair rows: particle {i} owns {owned} pairs but has {higher} higher-id neighbours"));
        }
        for (k, at) in (row.end - higher..row.end).enumerate() {
            let (id, expected) = (c.pair[at], c.pair_start[i] + k as u32);
            if id != expected {
                return Err(format!("pair ids: row entry {at} (particle {i}) has pair id {id}, not {expected}"));
            }
            let j = c.other[at] as usize;
            // The rows are symmetric (checked above): the mirror entry is there.
            let other = c.find(j, i as u32).map(|mirror| c.pair[mirror]);
            if other != Some(id) {
                let other = other.map_or("none".into(), |o| o.to_string());
                return Err(format!("pair ids: the pair {i}–{j} has id {id} in {i}'s row but {other} in {j}'s"));
            }
        }
    }
    Ok(())
}

/// A saved clump set fits the model it is loaded into: every member a live element marked as a
/// member, of one clump, its body sound.
fn check_clumps(c: &Clumps, fixed: &[u8]) -> Result<(), String> {
    use crate::state::particles::dof;
    let n = fixed.len();
    let shaped = c.of.len() == n
        && c.member_start.len() == c.bodies.len() + 1
        && c.member_start.first() == Some(&0)
        && c.member_start.windows(2).all(|w| w[0] < w[1])
        && c.member_start.last().map(|&e| e as usize) == Some(c.members.len())
        && c.offsets.len() == c.members.len();
    if !shaped {
        return Err("the clumps' member lists do not match their bodies or the elements".into());
    }
    for (k, b) in c.bodies.iter().enumerate() {
        let finite = [b.mass, b.inertia.x, b.inertia.y, b.inertia.z].iter().all(|v| v.is_finite() && *v > 0.0)
            && b.pos.iter().chain(b.vel.iter()).chain(b.ang_mom.iter()).chain(&b.orientation).all(|v| v.is_finite());
        let members_sound = c.members[c.range(k)]
            .iter()
            .all(|&i| (i as usize) < n && c.of[i as usize] == k as u32 && fixed[i as usize] & dof::CLUMPED != 0);
        if !finite || !members_sound {
            return Err(format!("clump {k} has an unsound body or a member that is not marked as its own"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::pore_flow::{BoundaryKind, PoreRegion};
    use crate::Material;

    // A format-7 file written before the pore heat section existed (its pore flow section
    // only) still loads: water's thermal properties, no permeability factors, no region
    // temperatures, the regions' totals at zero, and the pores take temperatures when heat is
    // switched on.
    #[test]
    fn a_pore_flow_file_without_the_pore_heat_section_loads_with_its_defaults() {
        let mut m = Model::new();
        let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4e-3).unwrap());
        let mat = mat.unwrap();
        for i in 0..27 {
            let x = Vec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * 1e-3;
            m.add_particle(x, 0.4e-3, mat).unwrap();
        }
        m.enable_pore_flow().unwrap();
        let region = PoreRegion::Point(Vec3::repeat(1e-3));
        m.add_pore_boundary_at(region, BoundaryKind::Pressure(1e3), Some(350.0)).unwrap();
        let old = encode_sections(&m, b"", |s| (!matches!(s, Section::PoreHeat { .. })).then_some(s));
        let loaded = decode(&old).unwrap().model;
        let f = loaded.pores.as_ref().unwrap();
        assert_eq!(loaded.settings.pores.boundaries[0].temperature, None);
        assert_eq!(f.fluid.heat, FluidHeat::default());
        assert!(f.fluid.permeability.is_empty() && f.temperature.is_empty());
        assert_eq!(f.region_mass, vec![0.0]);
        assert_eq!(f.mass, m.pores.as_ref().unwrap().mass);
        // And the full file carries them.
        let loaded = decode(&encode(&m, b"")).unwrap().model;
        assert_eq!(loaded.settings.pores.boundaries[0].temperature, Some(350.0));
        assert_eq!(loaded.pores.as_ref().unwrap().region_mass, m.pores.as_ref().unwrap().region_mass);
    }

    // A file written before the effects' states (moisture in a section of its own, format 7)
    // loads moisture's settings and water lanes as the state section does.
    #[test]
    fn a_moisture_section_of_an_older_file_loads_into_the_effects_state() {
        let mut m = Model::new();
        let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4e-3).unwrap());
        let mat = mat.unwrap();
        for i in 0..3 {
            m.add_particle(Vec3::new(i as f64 * 0.8e-3, 0.0, 0.0), 0.4e-3, mat).unwrap();
        }
        m.effects.moisture.settings.initial = 0.25;
        m.enable_moisture();
        m.set_moisture_material("grain", 1e-3).unwrap();
        m.set_radius_table(Some(vec![(0.0, 0.9), (0.3, 1.0)])).unwrap();
        m.effects.moisture.lanes.water[1] = 0.1;
        let older = |s: Section| match s {
            Section::Effect { name, state } if name == "moisture" => {
                let MoistureState { settings, lanes } = postcard::from_bytes(&state).unwrap();
                Some(Section::Moisture { settings, lanes })
            }
            s => Some(s),
        };
        let old = encode_sections(&m, b"", older);
        assert_ne!(old, encode(&m, b""), "the older file carries moisture in its own section");
        for file in [old, encode(&m, b"")] {
            let loaded = decode(&file).unwrap().model;
            assert_eq!(loaded.effects, m.effects);
        }
        // A forged older section is checked as the state section is.
        let forged = encode_sections(&m, b"", |s| match older(s)? {
            Section::Moisture { settings, mut lanes } => {
                lanes.mode.pop();
                Some(Section::Moisture { settings, lanes })
            }
            s => Some(s),
        });
        assert!(decode(&forged).is_err());
    }

    // The same for the confining pressure's section of its own, checked against the walls.
    #[test]
    fn a_confinement_section_of_an_older_file_loads_into_the_effects_state() {
        use crate::effects::confining_pressure::Confinement;
        use crate::walls::Wall;
        let mut m = Model::new();
        let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4e-3).unwrap());
        m.add_particle(Vec3::zeros(), 0.4e-3, mat.unwrap()).unwrap();
        for (name, z, n) in [("bottom", -1e-3, 1.0), ("top", 1e-3, -1.0)] {
            m.add_wall(Wall::plane(name, Vec3::new(0.0, 0.0, z), Vec3::new(0.0, 0.0, n), 1e-4).unwrap()).unwrap();
        }
        let (bottom, top) = ("bottom".to_string(), "top".to_string());
        let c = Confinement { pressure: 1e5, axis: [0.0, 0.0], bottom, top, bands: 2, sectors: 6 };
        m.effects.confining_pressure.confinement = Some(c);
        let older = |s: Section| match s {
            Section::Effect { name, state } if name == "confining_pressure" => {
                let ConfiningState { confinement } = postcard::from_bytes(&state).unwrap();
                Some(Section::Confinement { settings: confinement.unwrap() })
            }
            s => Some(s),
        };
        for file in [encode_sections(&m, b"", older), encode(&m, b"")] {
            assert_eq!(decode(&file).unwrap().model.effects, m.effects);
        }
        // A platen the model lacks is refused, in either section.
        m.walls.pop();
        m.wall_contacts.truncate(m.len());
        for file in [encode_sections(&m, b"", older), encode(&m, b"")] {
            let Err(e) = decode(&file) else { panic!("a missing platen loads") };
            let e = e.to_string();
            assert!(e.contains("names a platen the model does not have"), "{e}");
        }
    }

    // The same for the periodic cell's section of its own.
    #[test]
    fn a_periodic_section_of_an_older_file_loads_into_the_effects_state() {
        use crate::effects::periodic::Periodic;
        let mut m = Model::new();
        let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4e-3).unwrap());
        m.add_particle(Vec3::repeat(1e-3), 0.4e-3, mat.unwrap()).unwrap();
        m.effects.periodic.cell = Some(Periodic { axes: [Some([0.0, 2e-3]), None, None], shear: None });
        let older = |s: Section| match s {
            Section::Effect { name, state } if name == "periodic" => {
                let PeriodicState { cell } = postcard::from_bytes(&state).unwrap();
                Some(Section::Periodic { cell: cell.unwrap() })
            }
            s => Some(s),
        };
        for file in [encode_sections(&m, b"", older), encode(&m, b"")] {
            assert_eq!(decode(&file).unwrap().model.effects, m.effects);
        }
        m.effects.periodic.cell = Some(Periodic { axes: [Some([2e-3, 0.0]), None, None], shear: None });
        for file in [encode_sections(&m, b"", older), encode(&m, b"")] {
            let Err(e) = decode(&file) else { panic!("an empty span loads") };
            assert!(e.to_string().contains("not finite [lo, hi) with lo < hi"), "{e}");
        }
    }
}
