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
//! network and fluid, moisture with its water lanes, the pore fluid's heat (its temperatures,
//! thermal properties, permeability factors, region temperatures and totals) — from format 7, and
//! the energy account's body work with the body fields it last saw (format 8: an older file loads
//! with no body work and the fields it holds as the ones seen, `BodyWork::from_fields`). The engine
//! keeps no other state between steps and draws no random numbers while stepping (the box
//! builder's generator is spent once the box is built), so a loaded model steps exactly as
//! the saved one would have. The annex is the host's own data (its record tables), opaque here.
//!
//! The engine does no file I/O: hosts write the bytes (atomically) and read them back.

use crate::body_potential::{BodyFields, BodyWork};
use crate::fields::{HeatSettings, WaterTable};
use crate::model::Model;
use crate::moisture::MoistureSettings;
use crate::physics::rolling_resistance::RollingResistance;
use crate::physics::Vec3;
use crate::pores::coupling::PoreSettings;
use crate::pores::flow::{PoreBoundary, PoreFlow};
use crate::pores::{Fluid, FluidHeat};
use crate::provenance::Provenance;
use crate::state::moisture::MoistureLanes;
use crate::state::parallel_bonds::ParallelBonds;
use crate::state::thermal::ThermalLanes;
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
        "checkpoint format version {found} is not supported (this build reads version {supported}): load it with \
         the matdem-rs that wrote it, or re-create it with this one"
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
    /// Moisture: the scene's settings (diffusivities, tables) and the water lanes.
    Moisture { settings: MoistureSettings, lanes: MoistureLanes },
    /// What pore flow gained after its first section (written after it, whenever it is):
    /// the fluid's thermal properties and per-material permeability factors, the boundary
    /// regions' temperatures (the scene's list), and while pore flow is on the pores'
    /// temperatures and each region's booked mass and heat. A file without it loads with
    /// water's thermal properties, no factors, no region temperatures and zero totals.
    PoreHeat { settings: PoreHeatSettings, flow: Option<PoreHeatState> },
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
        if m.settings.moisture != MoistureSettings::default() || m.particles.moisture.allocated(m.len()) {
            let (settings, lanes) = (m.settings.moisture.clone(), m.particles.moisture.clone());
            out.push(Section::Moisture { settings, lanes });
        }
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
                if !lanes.consistent(m.len()) {
                    return Err("water lanes do not match the particles".into());
                }
                m.settings.moisture = settings;
                m.particles.moisture = lanes;
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
    encode_sections(model, annex, |_| true)
}

/// [`encode`] with only the sections `keep` keeps (a file as an older build wrote it, for
/// tests).
fn encode_sections(model: &Model, annex: &[u8], keep: impl Fn(&Section) -> bool) -> Vec<u8> {
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
        sections: Section::of(model).into_iter().filter(|s| keep(s)).collect(),
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
    let mut p = PayloadIn::read(payload, version).map_err(|e| {
        // The writer's version leads the payload, so it can usually be read even when the
        // model that follows cannot.
        let writer = postcard::take_from_bytes::<String>(payload).map(|(w, _)| w).unwrap_or_else(|_| "?".into());
        CheckpointError::Incompatible { writer, reason: e.to_string() }
    })?;
    p.model.parallel_bonds = p.parallel_bonds;
    p.model.settings.heat = p.fields.heat;
    p.model.settings.water = p.fields.water;
    p.model.particles.thermal = p.fields.thermal;
    // After the fields, whose water table an older file's derived account takes as seen.
    p.model.body_work = p.body_work.unwrap_or_else(|| BodyWork::from_fields(BodyFields::of(&p.model)));
    for (m, prov) in p.model.materials.iter_mut().zip(p.provenance) {
        m.provenance = prov;
    }
    let state = &mut p.model.contacts.state;
    for &(e, w) in &p.weakened {
        match state.get_mut(e as usize) {
            Some(s) if s.bonded => s.weakened = w,
            _ => {
                let reason = format!("a bond strength share refers to row entry {e}, not a bond");
                return Err(CheckpointError::Incompatible { writer: p.writer, reason });
            }
        }
    }
    check_consistent(&p.model).map_err(|reason| CheckpointError::Incompatible { writer: p.writer.clone(), reason })?;
    for section in p.sections {
        section
            .apply(&mut p.model)
            .map_err(|reason| CheckpointError::Incompatible { writer: p.writer.clone(), reason })?;
    }
    Ok(Checkpoint { model: p.model, annex: p.annex })
}

/// Lane lengths that must agree before the model is stepped (a well-formed but inconsistent
/// payload would otherwise index out of bounds).
fn check_consistent(m: &Model) -> Result<(), String> {
    let p = &m.particles;
    let n = p.len();
    let lanes = [p.radius.len(), p.vel.len(), p.mass.len(), p.force.len(), p.material.len(), p.fixed.len()];
    if lanes.iter().chain([&p.origin.len()]).any(|&l| l != n) {
        return Err("particle lanes of different lengths".into());
    }
    // A ledger lane is allocated (one entry per particle) or absent (empty) until a plan books it.
    if p.heat.lanes().iter().any(|l| !l.is_empty() && l.len() != n) {
        return Err("heat ledger does not match the particles".into());
    }
    if !p.thermal.consistent(n) {
        return Err("thermal lanes do not match the particles".into());
    }
    if let Some(rot) = &p.rotation {
        if rot.ang_vel.len() != n || rot.torque.len() != n {
            return Err("rotation lanes do not match the particles".into());
        }
    }
    if p.material.iter().any(|&k| k as usize >= m.materials.len()) {
        return Err("a particle refers to a missing material".into());
    }
    if m.wall_contacts.len() != n * m.walls.len() {
        return Err("wall contact states do not match particles × walls".into());
    }
    let c = &m.contacts;
    if !c.row_start.is_empty() {
        let rows_ok = c.row_start.len() == n + 1
            && c.row_start.windows(2).all(|w| w[0] <= w[1])
            && c.row_start[n] as usize == c.other.len()
            && c.state.len() == c.other.len()
            && c.other.iter().all(|&j| (j as usize) < n);
        if !rows_ok {
            return Err("neighbour rows do not match the particles".into());
        }
    }
    if c.has_pair_ids() && c.pair.iter().any(|&k| k as usize >= c.pair_count()) {
        return Err("pair ids out of range".into());
    }
    if !m.parallel_bonds.consistent(n) {
        return Err("parallel bond rows do not match the particles".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pores::{BoundaryKind, PoreRegion};
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
        let old = encode_sections(&m, b"", |s| !matches!(s, Section::PoreHeat { .. }));
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
}
