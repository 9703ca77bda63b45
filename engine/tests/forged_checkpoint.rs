//! Forged checkpoints: a `.mdem` file may come from anyone (a shared package ships one beside
//! its script), and its CRC-32 only tells damage from an intact copy, not a forgery from the
//! real thing. Whatever a forged payload holds, loading it returns the model or a refusal that
//! says what is wrong, and a model that loads steps on the CPU backend without a panic.
//!
//! The payloads are forged three ways, each resealed (header length and CRC-32 recomputed):
//! 1–4 flipped bits anywhere; a length, count or index field (a varint of a value the model
//! has as a count) overwritten with a nearby, zero or huge value; and one entry of an index
//! lane of the decoded model replaced, or one lane shortened, then encoded by the engine.

use matdem_engine::backend::RunControl;
use matdem_engine::builder::{BoxSpec, Container, SizeClass};
use matdem_engine::checkpoint::{decode, encode, CheckpointError};
use matdem_engine::effects::conduction::ThermalProps;
use matdem_engine::effects::parallel_bond::physics::ParallelBondParams;
use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, PoreRegion};
use matdem_engine::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
use matdem_engine::{Material, Model, Simulation, Vec3, Wall, WallMotion};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::OnceLock;

const HEADER: usize = 20;

/// A 3 mm box of grains (one material, r 0.4–0.55 mm) under 50 g with local damping: the
/// base of both scenes.
fn grain_box(height: f64, seed: u64, top_platen: bool) -> Model {
    let mut mat = Material::from_micro("grain", 2650.0, 2e4, 8e3, 2e-6, 0.02, 0.5, 0.5e-3).unwrap();
    mat.restitution = 0.5;
    let mut m = Model::new();
    m.add_material(mat).unwrap();
    let spec = BoxSpec {
        container: Container::Cuboid { width: 3e-3, length: 3e-3 },
        height,
        classes: vec![SizeClass { r_min: 0.4e-3, r_max: 0.55e-3, mass_ratio: 1.0 }],
        target_porosity: 0.4,
        seed,
        top_platen,
    };
    spec.build_into(&mut m).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81 * 50.0);
    m.settings.local_damping = 0.3;
    m
}

/// A small box of grains settled under gravity: walls (a servo platen among them), bonds with
/// some weakened to a joint, parallel bonds, groups, rotation, heat with expansion, the heat
/// ledger, contact dashpots and a water table.
fn bonded_box() -> Model {
    let mut m = grain_box(3.5e-3, 3, true);
    m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    sim.run(600, &RunControl::default(), &mut |_| {}).unwrap();
    let mut m = sim.model;
    let n = m.len() as u32;
    m.connect(None, 5e-5).unwrap();
    let p = ParallelBondParams { lambda: 0.8, e_star: 1e6, k_ratio: 2.6, sigma_c: 2e3, cohesion: 2e3, phi: 0.4 };
    m.bond_parallel(p).unwrap();
    // Bonded contacts beside the parallel bonds, some weakened to a joint.
    m.connect(None, 5e-5).unwrap();
    m.set_bond_strength(|i, j| (i + j) % 3 == 0, 0.3).unwrap();
    m.groups.set("low", (0..n / 2).collect());
    m.groups.set("high", (n / 2..n).collect());
    m.enable_heat();
    m.set_thermal_material("grain", ThermalProps { conductivity: 3.0, specific_heat: 800.0, expansion: 1e-5 }).unwrap();
    // A water table over the lower half: the submerged cap reads the radii expansion writes.
    m.settings.water.level = Some(1.5e-3);
    let dt = m.clock.dt;
    let r = m.mean_radius();
    m.wall_mut("top_platen").unwrap().motion = WallMotion::Servo { stress: 2e3, max_speed: 2e-3 * r / dt };
    // Applied loads (their lanes and work account) beside the rotation angles.
    m.apply_force(&[0, 1], Vec3::new(1e-5, 0.0, -1e-5)).unwrap();
    m.apply_torque(&[2], Vec3::new(0.0, 1e-9, 0.0)).unwrap();
    let mut sim = Simulation::new(m);
    sim.run(50, &RunControl::default(), &mut |_| {}).unwrap();
    sim.model
}

/// The same kind of box with the optional stages' sections: pore flow with a reservoir,
/// moisture, epsd rolling resistance, a water table and a cone.
fn wet_box() -> Model {
    let mut m = grain_box(3e-3, 5, false);
    m.settings.rotation = true;
    m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    sim.run(600, &RunControl::default(), &mut |_| {}).unwrap();
    let mut m = sim.model;
    m.connect(None, 5e-5).unwrap();
    m.settings.rolling = Some(RollingResistance::new(RollingModel::Epsd, 0.2, 0.3).unwrap());
    // A soft fluid: a few flow sub-steps a step keep the cases cheap.
    m.settings.pores.fluid = Fluid { bulk_modulus: 1e4, viscosity: 1e-2, max_substeps: 5000, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    let bottom = PoreRegion::Box { lo: Vec3::new(-1.0, -1.0, -1.0), hi: Vec3::new(1.0, 1.0, 1.2e-3) };
    m.add_pore_boundary(bottom, BoundaryKind::Pressure(2e3)).unwrap();
    m.add_pore_boundary(PoreRegion::Elements(vec![0, 1, 2]), BoundaryKind::Flux(1e-12)).unwrap();
    m.enable_moisture();
    m.set_moisture_material("grain", 1e-3).unwrap();
    m.set_strength_table(Some(vec![(0.0, 1.0), (0.5, 0.5)])).unwrap();
    m.groups.set("wet", vec![0, 1]);
    m.settings.water.level = Some(1e-3);
    // A penetrometer cone above the sample (its distance clamps along the cone's profile).
    let cone = Wall::cone("cone", Vec3::new(1.5e-3, 1.5e-3, 3.2e-3), Vec3::z(), 0.5, 0.5e-3, 1e-3).unwrap();
    m.add_wall(cone).unwrap();
    let mut sim = Simulation::new(m);
    sim.run(50, &RunControl::default(), &mut |_| {}).unwrap();
    sim.model
}

/// The file around a (forged) payload: header with its length, CRC-32 of all before it.
fn reseal(file: &[u8], payload: &[u8]) -> Vec<u8> {
    let mut out = file[..12].to_vec();
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// postcard's varint (LEB128) of `v`: its lengths, counts and ids.
fn varint(mut v: u64) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let b = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(b);
            return out;
        }
        out.push(b | 0x80);
    }
}

/// Every count the model has (lane lengths, ids at the ends of ranges): their varints in the
/// payload include its length prefixes and the ends of its CSR rows.
fn counts(m: &Model) -> Vec<u64> {
    let n = m.len();
    let c = &m.contacts;
    let pb = &m.parallel_bonds;
    let mut v = vec![
        n,
        n + 1,
        m.walls.len(),
        n * m.walls.len(),
        c.other.len(),
        c.other.len() / 2,
        m.materials.len(),
        m.breakages.len(),
        pb.other.len(),
        m.groups.names().count(),
        m.particles.thermal.temperature.len(),
        m.effects.moisture.lanes.water.len(),
    ];
    for g in m.groups.names() {
        v.push(m.groups.get(g).unwrap().len());
    }
    if let Some(f) = &m.pores {
        let net = &f.network;
        v.extend([
            net.tri.tets.len(),
            net.tri.points.len(),
            net.pore_count(),
            net.pore_count() + 1,
            net.throats.len(),
            net.row.len(),
            net.pore_tets.len(),
            net.elem_corners.len(),
            f.boundaries.len(),
        ]);
    }
    let mut v: Vec<u64> = v.into_iter().filter(|&x| x > 0).map(|x| x as u64).collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// Where the payload holds one of `counts` as a varint: the length prefixes of the particle,
/// row, wall, group and pore lanes are among them (and many a value that only looks alike).
fn count_positions(payload: &[u8], counts: &[u64]) -> Vec<(usize, usize)> {
    let encoded: Vec<Vec<u8>> = counts.iter().map(|&c| varint(c)).collect();
    let mut out = Vec::new();
    for at in 0..payload.len() {
        for e in &encoded {
            if payload[at..].starts_with(e) {
                out.push((at, e.len()));
            }
        }
    }
    out
}

/// One forgery of a valid file.
#[derive(Debug, Clone)]
enum Forgery {
    /// Flip these bits of the payload (bit index from its start).
    Bits(Vec<usize>),
    /// Replace the varint at `candidate` (an index into the count positions) by one of `value`.
    Count { candidate: usize, value: u64 },
    /// Set entry `entry` (mod the lane's length) of index lane `lane` to `value`, or shorten
    /// the lane by one when `value` is `None`.
    Lane { lane: usize, entry: usize, value: Option<u32> },
}

/// The index lanes a structured forgery writes: each gets the model, an entry and a value
/// (`None`: drop the last entry) and says whether it changed anything.
type LaneFn = fn(&mut Model, usize, Option<u32>) -> bool;

fn set<T>(lane: &mut Vec<T>, entry: usize, value: Option<T>) -> bool {
    if lane.is_empty() {
        return false;
    }
    match value {
        Some(v) => {
            let k = entry % lane.len();
            lane[k] = v;
        }
        None => {
            lane.pop();
        }
    }
    true
}

const LANES: &[(&str, LaneFn)] = &[
    ("row_start", |m, e, v| set(&mut m.contacts.row_start, e, v)),
    ("other", |m, e, v| set(&mut m.contacts.other, e, v)),
    ("pair", |m, e, v| set(&mut m.contacts.pair, e, v)),
    ("pair_start", |m, e, v| set(&mut m.contacts.pair_start, e, v)),
    ("wall_near", |m, e, v| set(&mut m.contacts.wall_near, e, v.map(|x| x as u8))),
    ("built_at", |m, e, v| set(&mut m.contacts.built_at, e, v.map(|x| Vec3::repeat(x as f64)))),
    ("contact states", |m, e, v| v.is_none() && set(&mut m.contacts.state, e, None)),
    ("rolling", |m, e, v| v.is_none() && set(&mut m.contacts.rolling, e, None)),
    ("wall_rolling", |m, e, v| v.is_none() && set(&mut m.wall_rolling, e, None)),
    ("wall_contacts", |m, e, v| v.is_none() && set(&mut m.wall_contacts, e, None)),
    ("walls_at_build", |m, e, v| v.is_none() && set(&mut m.contacts.walls_at_build, e, None)),
    ("material", |m, e, v| set(&mut m.particles.material, e, v)),
    ("fixed", |m, e, v| set(&mut m.particles.fixed, e, v.map(|x| x as u8))),
    ("radius", |m, e, v| set(&mut m.particles.radius, e, v.map(|x| x as f64 * 1e-4 - 1e-3))),
    ("pos", |m, e, v| set(&mut m.particles.pos, e, v.map(|x| Vec3::repeat(f64::from_bits(x as u64 * 0x1234_5677))))),
    ("ang_vel", |m, e, v| v.is_none() && m.particles.rotation.as_mut().is_some_and(|r| set(&mut r.ang_vel, e, None))),
    ("angle", |m, e, v| v.is_none() && m.particles.rotation.as_mut().is_some_and(|r| set(&mut r.angle, e, None))),
    ("applied force", |m, e, v| v.is_none() && set(&mut m.particles.applied.force, e, None)),
    ("applied offset", |m, e, v| v.is_none() && set(&mut m.particles.applied.offset, e, None)),
    ("heat ledger", |m, e, v| v.is_none() && set(&mut m.particles.heat.damping, e, None)),
    ("thermal mode", |m, e, v| set(&mut m.particles.thermal.mode, e, v.map(|x| x as u8))),
    ("radius0", |m, e, v| v.is_none() && set(&mut m.particles.thermal.radius0, e, None)),
    ("moisture mode", |m, e, v| set(&mut m.effects.moisture.lanes.mode, e, v.map(|x| x as u8))),
    ("water", |m, e, v| v.is_none() && set(&mut m.effects.moisture.lanes.water, e, None)),
    ("group", |m, _, v| {
        m.groups.set("forged", v.into_iter().collect());
        true
    }),
    ("breakage", |m, _, v| {
        let Some(&b) = m.breakages.first() else { return false };
        let v = v.unwrap_or(u32::MAX);
        m.breakages.push(matdem_engine::model::Breakage { i: v, j: v.wrapping_add(1), ..b });
        true
    }),
    ("parallel row_start", |m, e, v| set(&mut m.parallel_bonds.row_start, e, v)),
    ("parallel other", |m, e, v| set(&mut m.parallel_bonds.other, e, v)),
    ("parallel state", |m, e, v| v.is_none() && set(&mut m.parallel_bonds.state, e, None)),
    ("tet corner", |m, e, v| pores(m, |f| edit_tet(f, e, v, false))),
    ("tet neighbour", |m, e, v| pores(m, |f| edit_tet(f, e, v, true))),
    ("tet_pore", |m, e, v| pores(m, |f| set(&mut f.network.tet_pore, e, v))),
    ("pore_tet_start", |m, e, v| pores(m, |f| set(&mut f.network.pore_tet_start, e, v))),
    ("pore_tets", |m, e, v| pores(m, |f| set(&mut f.network.pore_tets, e, v))),
    ("throat a", |m, e, v| pores(m, |f| edit_throat(f, e, v, 0))),
    ("throat b", |m, e, v| pores(m, |f| edit_throat(f, e, v, 1))),
    ("throat tet", |m, e, v| pores(m, |f| edit_throat(f, e, v, 2))),
    ("throat face", |m, e, v| pores(m, |f| edit_throat(f, e, v, 3))),
    ("pore row_start", |m, e, v| pores(m, |f| set(&mut f.network.row_start, e, v))),
    ("pore row", |m, e, v| pores(m, |f| set(&mut f.network.row, e, v))),
    ("elem_start", |m, e, v| pores(m, |f| set(&mut f.network.elem_start, e, v))),
    ("elem_corners", |m, e, v| pores(m, |f| set(&mut f.network.elem_corners, e, v))),
    ("pore region", |m, e, v| pores(m, |f| set(&mut f.region, e, v))),
    ("pore mass", |m, e, v| pores(m, |f| v.is_none() && set(&mut f.mass, e, None))),
    ("pore temperature", |m, e, v| pores(m, |f| v.is_none() && set(&mut f.temperature, e, None))),
    ("boundary elements", |m, _, v| {
        pores(m, |f| {
            let b = f.boundaries.iter_mut().find_map(|b| match &mut b.region {
                PoreRegion::Elements(ids) => Some(ids),
                _ => None,
            });
            b.is_some_and(|ids| set(ids, 0, v))
        })
    }),
];

fn pores(m: &mut Model, f: impl FnOnce(&mut matdem_engine::effects::pore_flow::PoreFlow) -> bool) -> bool {
    m.pores.as_deref_mut().is_some_and(f)
}

/// Sets corner (or neighbour) `e % 4` of tetrahedron `e / 4`, or drops the last one.
fn edit_tet(f: &mut matdem_engine::effects::pore_flow::PoreFlow, e: usize, v: Option<u32>, neighbour: bool) -> bool {
    let tets = &mut f.network.tri.tets;
    let Some(x) = v else { return set(tets, 0, None) };
    let k = (e / 4) % tets.len();
    if neighbour {
        tets[k].n[e % 4] = x;
    } else {
        tets[k].v[e % 4] = x;
    }
    true
}

/// Sets one field of throat `e` (`a`, `b`, `tet`, `face`), or drops the last throat.
fn edit_throat(f: &mut matdem_engine::effects::pore_flow::PoreFlow, e: usize, v: Option<u32>, field: usize) -> bool {
    let throats = &mut f.network.throats;
    let Some(x) = v else { return set(throats, 0, None) };
    let k = e % throats.len();
    let t = &mut throats[k];
    match field {
        0 => t.a = x,
        1 => t.b = x,
        2 => t.tet = x,
        _ => t.face = x as u8,
    }
    true
}

/// A valid file and what the forgeries need of it.
struct Original {
    name: &'static str,
    file: Vec<u8>,
    model: Model,
    counts: Vec<(usize, usize)>,
}

impl Original {
    fn new(name: &'static str, model: Model) -> Self {
        let file = encode(&model, b"annex");
        let counts = count_positions(&file[HEADER..file.len() - 4], &counts(&model));
        Original { name, file, model, counts }
    }

    fn payload(&self) -> &[u8] {
        &self.file[HEADER..self.file.len() - 4]
    }

    /// The forged file, or `None` when the forgery changes nothing.
    fn forge(&self, f: &Forgery) -> Option<Vec<u8>> {
        let mut payload = self.payload().to_vec();
        match f {
            Forgery::Bits(bits) => {
                for &b in bits {
                    let b = b % (payload.len() * 8);
                    payload[b / 8] ^= 1 << (b % 8);
                }
                Some(reseal(&self.file, &payload))
            }
            Forgery::Count { candidate, value } => {
                let (at, len) = self.counts[candidate % self.counts.len()];
                payload.splice(at..at + len, varint(*value));
                Some(reseal(&self.file, &payload))
            }
            Forgery::Lane { lane, entry, value } => {
                let mut m = self.model.clone();
                LANES[lane % LANES.len()].1(&mut m, *entry, *value).then(|| encode(&m, b"annex"))
            }
        }
    }
}

fn forgery() -> impl Strategy<Value = Forgery> {
    let value = prop_oneof![
        Just(0u64),
        1u64..4,
        30u64..140,
        (u32::MAX as u64 - 2)..=(u32::MAX as u64),
        Just(1u64 << 31),
        Just(1u64 << 36),
        Just(1u64 << 60),
        Just(u64::MAX),
        any::<u64>(),
    ];
    let index = prop_oneof![
        3 => (0u32..200).prop_map(Some),
        1 => (u32::MAX - 1..=u32::MAX).prop_map(Some),
        1 => any::<u32>().prop_map(Some),
        1 => Just(None),
    ];
    prop_oneof![
        4 => prop::collection::vec(any::<usize>(), 1..=4).prop_map(Forgery::Bits),
        2 => (any::<usize>(), value).prop_map(|(candidate, value)| Forgery::Count { candidate, value }),
        2 => (0..LANES.len(), any::<usize>(), index).prop_map(|(lane, entry, value)| Forgery::Lane { lane, entry, value }),
    ]
}

/// Loads a forged file and, when it loads, steps it: fused steps, then observed ones.
/// `Err` with the refusal's message, `Ok` when it loaded (the run may still stop with an
/// error: the guard refusing a forged state is a run error, not a panic).
fn load_and_step(file: &[u8]) -> Result<(), CheckpointError> {
    let mut model = decode(file)?.model;
    // Sub-step counts are loop counts, not indices: a forged 4·10⁹ makes a step take hours, as
    // a script asking for them would (a long run, not a fault). Capped here so the test ends.
    let s = &mut model.settings;
    s.heat.substeps = s.heat.substeps.min(64);
    s.pores.fluid.max_substeps = s.pores.fluid.max_substeps.min(5000);
    let w = &mut model.effects.moisture.settings;
    w.substeps = w.substeps.min(64);
    if let Some(f) = model.pores.as_deref_mut() {
        f.fluid.max_substeps = f.fluid.max_substeps.min(5000);
    }
    let mut sim = Simulation::new(model);
    let _ = sim.run(2, &RunControl::default(), &mut |_| {});
    let _ = sim.run_sampled(2, 1, &RunControl::default(), &mut |_| {}, &mut |_| {});
    Ok(())
}

/// The two scenes' intact files, built once for the tests here.
fn originals() -> &'static [Original; 2] {
    static ORIGINALS: OnceLock<[Original; 2]> = OnceLock::new();
    ORIGINALS.get_or_init(|| [Original::new("bonded box", bonded_box()), Original::new("wet box", wet_box())])
}

/// The panic's message.
fn message(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default()
}

// Every panic is collected, with its forgery, and the test fails listing them all.
//
// On the engine before these load checks (issue 28), 30,000 cases found 370–432 panics a run,
// all in files the decoder accepted: a pair row start moved (`slice index starts at 46 but
// ends at 29`, `range end index 76 out of range for slice of length 53`, a start wrapped to
// 2⁶⁴ − 13: contact_forces.rs:192, 193 and 331, the pair and gather passes), a wall mask naming
// a wall the model lacks (`the len is 6 but the index is 6`, wall_forces.rs:148), a pore without
// a tetrahedron (`the len is 0 but the index is 0`, effects/pore_flow/network.rs:311) and `f64::clamp` given
// a bound it panics on; a heat sub-step count forged to ~4·10⁹ hung the conduction stage (hence
// the cap in `load_and_step`). With the checks, the water table added to the bonded box found
// 2 more in 30,000: forged thermal lanes expanded a radius below zero, and the submerged cap's
// `clamp(0, 2r)` panicked (effects/buoyancy/physics.rs, now min/max). 10,000 cases (some 8,800 forged
// files; a lane edit that does not apply is skipped) take about 2 s alone in release mode.
#[test]
fn a_checkpoint_with_flipped_bits_loads_or_is_refused_never_panics() {
    let originals = originals();
    for o in originals {
        load_and_step(&o.file).unwrap_or_else(|e| panic!("{}: the intact file must load: {e}", o.name));
    }
    let mut runner = TestRunner::new(Config { cases: 10000, failure_persistence: None, ..Config::default() });
    let panics = std::cell::RefCell::new(Vec::new());
    let (loaded, refused) = (std::cell::Cell::new(0u32), std::cell::Cell::new(0u32));
    let start = std::time::Instant::now();
    let result = runner.run(&(0..originals.len(), forgery()), |(k, f)| {
        let o = &originals[k];
        let Some(file) = o.forge(&f) else { return Ok(()) };
        match catch_unwind(AssertUnwindSafe(|| load_and_step(&file))) {
            Ok(Ok(())) => loaded.set(loaded.get() + 1),
            Ok(Err(e)) => {
                refused.set(refused.get() + 1);
                // The header is intact: a forged payload is corrupt, or (its writer's version
                // forged too) from another version; either way the message says what to do.
                let what_to_do = match &e {
                    CheckpointError::Corrupt { .. } => "save the model again",
                    CheckpointError::Incompatible { .. } => "re-create it with this one",
                    _ => "(neither corrupt nor incompatible)",
                };
                prop_assert!(e.to_string().contains(what_to_do), "{}: {f:?} refused as {e}", o.name);
            }
            Err(p) => panics.borrow_mut().push(format!("{}: {f:?}: {}", o.name, message(&*p))),
        }
        Ok(())
    });
    eprintln!(
        "forged checkpoints: {} loaded and stepped, {} refused, {} panicked in {:.1} s",
        loaded.get(),
        refused.get(),
        panics.borrow().len(),
        start.elapsed().as_secs_f64()
    );
    result.unwrap();
    let panics = panics.into_inner();
    assert!(panics.is_empty(), "{} forged files panicked:\n{}", panics.len(), panics.join("\n"));
}

// A length prefix forged to 2³⁶ or 2⁶⁰ elements (or u64::MAX) is refused without the
// decoder trying to allocate it (an abort no catch_unwind could report: this test process
// would die): serde preallocates at most 1 MiB of a sequence and postcard hints no more than
// the bytes left. Every varint of a count in both files is forged so; the first lane's length
// (the particles' positions, right after the writer's version) must be refused as corrupt.
#[test]
fn a_forged_huge_length_is_refused_without_allocating_it() {
    for o in originals() {
        let payload = o.payload();
        let first_lane = 1 + payload[0] as usize;
        let n = varint(o.model.len() as u64);
        assert_eq!(&payload[first_lane..first_lane + n.len()], &n[..], "{}: the positions' length", o.name);
        let mut forged = 0;
        for &(at, len) in std::iter::once(&(first_lane, n.len())).chain(&o.counts) {
            for huge in [1u64 << 36, 1 << 60, u64::MAX] {
                let mut p = payload.to_vec();
                p.splice(at..at + len, varint(huge));
                let file = reseal(&o.file, &p);
                let outcome = catch_unwind(AssertUnwindSafe(|| decode(&file).map(|_| ())));
                let outcome = outcome.unwrap_or_else(|p| panic!("{}: {huge} at byte {at}: {}", o.name, message(&*p)));
                if at == first_lane {
                    let e = outcome.expect_err("2^36 positions in a few kB");
                    assert!(matches!(&e, CheckpointError::Corrupt { reason } if reason.contains("decode")), "{e}");
                }
                forged += 1;
            }
        }
        assert!(forged > 300, "{}: only {forged} forgeries", o.name);
    }
}
