//! Checkpoints: a model saved mid-run and loaded into a fresh simulation continues bit for
//! bit like the run that never stopped; damaged or foreign files are refused with a message
//! that says what is wrong and what to do.

use matdem_engine::backend::RunControl;
use matdem_engine::builder::{BoxSpec, Container, SizeClass};
use matdem_engine::checkpoint::{decode, encode, CheckpointError, FORMAT_VERSION};
use matdem_engine::{Material, Model, Simulation, Vec3, WallMotion};

/// A small bonded sample under gravity in a box with a servo-controlled top platen, rotation
/// on, local damping and contact dashpots: every kind of state a checkpoint must carry
/// (pair shear and bond state, wall contact state, servo wall, heat ledger, breakages).
fn loaded_sample() -> Simulation {
    let mut mat = Material::from_micro("grain", 2650.0, 2e4, 8e3, 2e-6, 0.02, 0.5, 0.5e-3).unwrap();
    mat.restitution = 0.5;
    let mut m = Model::new();
    m.add_material(mat).unwrap();
    let spec = BoxSpec {
        container: Container::Cuboid { width: 4e-3, length: 4e-3 },
        height: 5e-3,
        classes: vec![SizeClass { r_min: 0.4e-3, r_max: 0.55e-3, mass_ratio: 1.0 }],
        target_porosity: 0.4,
        seed: 7,
        top_platen: true,
    };
    spec.build_into(&mut m).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81 * 50.0);
    m.settings.rotation = true;
    m.settings.local_damping = 0.3;
    m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    sim.run(3000, &RunControl::default(), &mut |_| {}).unwrap();
    sim.model.connect(None, 5e-5).unwrap();
    let dt = sim.model.clock.dt;
    let r = sim.model.mean_radius();
    sim.model.wall_mut("top_platen").unwrap().motion = WallMotion::Servo { stress: 2e3, max_speed: 2e-3 * r / dt };
    sim
}

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

#[test]
fn saved_and_loaded_model_continues_bitwise_like_the_uninterrupted_run() {
    let mut straight = loaded_sample();
    run(&mut straight, 700);
    // A joint: some bonds at 30 % of their strength (format 6 carries the shares).
    assert!(straight.model.set_bond_strength(|i, j| (i + j) % 3 == 0, 0.3).unwrap() > 0);
    let bytes = encode(&straight.model, b"host data");
    let shares = |m: &Model| m.contacts.state.iter().map(|s| s.weakened).collect::<Vec<_>>();
    let saved = shares(&straight.model);
    run(&mut straight, 1300);

    let loaded = decode(&bytes).unwrap();
    assert_eq!(loaded.annex, b"host data");
    assert!(saved.iter().any(|&w| w != 0) && shares(&loaded.model) == saved, "the joint's shares are saved");
    let mut resumed = Simulation::new(loaded.model);
    run(&mut resumed, 1300);

    let (a, b) = (&straight.model, &resumed.model);
    assert!(a.bond_count() > 0 && a.walls.iter().any(|w| w.contacts > 0), "the scene must exercise bonds and walls");
    assert_eq!(a.clock, b.clock);
    for i in 0..a.len() {
        for k in 0..3 {
            assert_eq!(a.particles.pos[i][k].to_bits(), b.particles.pos[i][k].to_bits(), "particle {i} position");
            assert_eq!(a.particles.vel[i][k].to_bits(), b.particles.vel[i][k].to_bits(), "particle {i} velocity");
        }
    }
    // Everything else (pair state, walls, heat, breakages) through the encoding itself.
    assert!(encode(a, b"") == encode(b, b""), "the resumed model differs from the uninterrupted one");
}

#[test]
fn a_flipped_byte_is_refused_as_corrupt() {
    let sim = loaded_sample();
    let mut bytes = encode(&sim.model, b"");
    let k = bytes.len() / 2;
    bytes[k] ^= 0x40;
    let e = decode(&bytes).unwrap_err();
    assert!(matches!(e, CheckpointError::Corrupt { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("corrupt") && msg.contains("checksum") && msg.contains("save the model again"), "{msg}");
}

#[test]
fn a_truncated_file_is_refused_with_its_size() {
    let sim = loaded_sample();
    let bytes = encode(&sim.model, b"");
    let cut = &bytes[..bytes.len() - 100];
    let e = decode(cut).unwrap_err();
    assert_eq!(e, CheckpointError::Truncated { expected: bytes.len() as u64, found: cut.len() as u64 }, "{e}");
    assert!(e.to_string().contains("truncated"), "{e}");
    assert!(matches!(decode(&bytes[..10]).unwrap_err(), CheckpointError::Truncated { .. }));
}

#[test]
fn another_format_version_is_refused_with_what_to_do() {
    let mut bytes = encode(&Model::new(), b"");
    bytes[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    let e = decode(&bytes).unwrap_err();
    assert_eq!(e, CheckpointError::UnsupportedVersion { found: FORMAT_VERSION + 1, supported: FORMAT_VERSION });
    assert!(e.to_string().contains("load it with the matdem-rs that wrote it"), "{e}");
}

#[test]
fn a_file_of_another_kind_is_refused_as_not_a_checkpoint() {
    let e = decode(b"step,time\n0,0\n").unwrap_err();
    assert_eq!(e, CheckpointError::NotACheckpoint);
    assert!(e.to_string().contains("d.save"), "{e}");
    assert_eq!(decode(b"").unwrap_err(), CheckpointError::NotACheckpoint);
}

#[test]
fn a_well_formed_payload_with_inconsistent_lanes_is_refused_not_stepped() {
    let mut m = loaded_sample().model;
    m.particles.radius.pop();
    let e = decode(&encode(&m, b"")).unwrap_err();
    assert!(matches!(e, CheckpointError::Incompatible { .. }), "{e:?}");
    assert!(e.to_string().contains("particle lanes"), "{e}");
}

#[test]
fn a_cancelled_balance_continued_with_balance_from_ends_like_the_uncancelled_one() {
    use matdem_engine::{Balance, Error};
    use std::sync::atomic::Ordering;
    for how in [Balance::Steps(900), Balance::Tolerance { ratio: 1e-9, max_steps: 900 }] {
        let mut straight = loaded_sample();
        let done = straight.balance(how, &RunControl::default(), &mut |_| {}).unwrap();

        let mut cut = loaded_sample();
        let ctl = RunControl::default();
        let flag = ctl.cancel.clone();
        // Cancel from the progress report after 300 steps, as a signal handler would.
        let e = cut.balance(how, &ctl, &mut |k| flag.store(k >= 300, Ordering::Relaxed)).unwrap_err();
        let Error::Cancelled { completed_steps } = e else { panic!("{e:?}") };
        assert_eq!(completed_steps, 300, "{how:?}");
        let bytes = encode(&cut.model, b"");
        let mut resumed = Simulation::new(decode(&bytes).unwrap().model);
        let rest = resumed.balance_from(how, completed_steps, &RunControl::default(), &mut |_| {}).unwrap();
        assert_eq!(rest, done, "{how:?}: same steps and unbalanced ratio");
        assert!(encode(&straight.model, b"") == encode(&resumed.model, b""), "{how:?}: state differs");
    }
}

#[test]
fn an_observer_sees_every_nth_step_and_changes_no_result() {
    use matdem_engine::simulation::Observer;
    use std::cell::RefCell;
    use std::rc::Rc;
    let mut plain = loaded_sample();
    run(&mut plain, 1000);
    let mut watched = loaded_sample();
    let seen = Rc::new(RefCell::new(Vec::new()));
    let log = seen.clone();
    watched.observer = Some(Observer {
        every: 37,
        call: Box::new(move |m| {
            log.borrow_mut().push(m.clock.step);
            Ok(())
        }),
    });
    run(&mut watched, 1000);
    let start = plain.model.clock.step - 1000;
    let expected: Vec<u64> = (start + 1..=start + 1000).filter(|s| s % 37 == 0).collect();
    assert_eq!(*seen.borrow(), expected);
    assert!(encode(&plain.model, b"") == encode(&watched.model, b""), "observing changed the run");
}

/// A loaded sample whose bonds are parallel bonds (rotation on, bonds loaded by gravity).
fn parallel_bonded_sample() -> Simulation {
    use matdem_engine::physics::parallel_bond::ParallelBondParams;
    let mut sim = loaded_sample();
    let p = ParallelBondParams { lambda: 0.8, e_star: 1e6, k_ratio: 2.6, sigma_c: 2e3, cohesion: 2e3, phi: 0.4 };
    sim.model.bond_parallel(p).unwrap();
    sim
}

// The parallel bonds' state (forces and moments, broken or intact) travels with the model:
// saved mid-run, loaded and continued, the model ends bit for bit as the straight run.
#[test]
fn a_model_with_parallel_bonds_continues_bitwise_after_a_checkpoint() {
    let mut straight = parallel_bonded_sample();
    run(&mut straight, 400);
    let bytes = encode(&straight.model, b"");
    run(&mut straight, 600);
    let mut resumed = Simulation::new(decode(&bytes).unwrap().model);
    run(&mut resumed, 600);
    let (a, b) = (&straight.model, &resumed.model);
    let pb = &a.parallel_bonds;
    assert!(pb.intact() > 0 && pb.state.iter().any(|s| s.normal != 0.0), "the bonds must be loaded");
    assert_eq!(pb.state, b.parallel_bonds.state);
    assert_eq!(a.particles.pos, b.particles.pos);
    assert_eq!(a.particles.rotation.as_ref().unwrap().ang_vel, b.particles.rotation.as_ref().unwrap().ang_vel);
    assert_eq!(a.breakages, b.breakages);
}

/// A checkpoint file of format `version` around `payload`.
fn framed(version: u32, payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(b"MDEMCKPT");
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

// Formats 2 (before parallel bonds: the payload ends at the annex), 3 (before the fields: it
// ends at the parallel bonds) and 4 (before the materials' provenance: it ends at the fields)
// still load, without what they lack. Their payloads are written here as those versions
// wrote them (postcard encodes a struct as the tuple of its fields).
#[test]
fn format_2_3_and_4_checkpoints_still_load() {
    let mut sim = parallel_bonded_sample();
    run(&mut sim, 50);
    let model = sim.model;
    let annex = b"annex".to_vec();
    let v2 = framed(2, &postcard::to_stdvec(&("0.1.0", &model, &annex)).unwrap());
    let v3 = framed(3, &postcard::to_stdvec(&("0.1.0", &model, &annex, &model.parallel_bonds)).unwrap());
    let fields = (&model.settings.heat, &model.settings.water, &model.particles.thermal);
    let v4 = framed(4, &postcard::to_stdvec(&("0.1.0", &model, &annex, &model.parallel_bonds, fields)).unwrap());
    let loaded = decode(&v2).unwrap();
    assert_eq!(loaded.annex, b"annex");
    assert_eq!(loaded.model.particles.pos, model.particles.pos);
    assert!(!loaded.model.parallel_bonds.enabled());
    assert_eq!(loaded.model.materials[0].provenance, Default::default());
    let loaded = decode(&v3).unwrap();
    assert_eq!(loaded.model.particles.pos, model.particles.pos);
    assert_eq!(loaded.model.parallel_bonds.state, model.parallel_bonds.state);
    assert_eq!(loaded.model.materials[0].provenance, Default::default());
    let loaded = decode(&v4).unwrap();
    assert_eq!(loaded.model.particles.pos, model.particles.pos);
    assert_eq!(loaded.model.parallel_bonds.state, model.parallel_bonds.state);
    assert_eq!(loaded.model.materials[0].provenance, Default::default());
}

/// A material's provenance (where each value came from) is saved with the model: a loaded
/// model prints the same derivations as the one that was saved.
#[test]
fn materials_keep_their_provenance_through_a_checkpoint() {
    let sim = loaded_sample();
    let saved = &sim.model.materials[0].provenance;
    assert!(
        matches!(saved.of("young"), Some(matdem_engine::provenance::Source::Derived(_))),
        "from_micro derives E = Kn/(πR): {saved:?}"
    );
    let back = decode(&encode(&sim.model, b"")).unwrap();
    assert_eq!(&back.model.materials[0].provenance, saved);
}

// Format 5 (before joints: the payload ends at the materials' provenance) still loads, with
// whole bonds; made from a format-6 file of a model without joints, whose payload ends with the
// 1 byte of an empty list of shares.
#[test]
fn format_5_and_6_checkpoints_still_load_with_whole_bonds_and_no_moisture() {
    let model = loaded_sample().model;
    let v7 = encode(&model, b"annex");
    let payload = &v7[20..v7.len() - 4];
    // The tail: no weakened bonds (format 6), no moisture (format 7).
    assert_eq!(&payload[payload.len() - 2..], [0, 0], "no weakened bonds, no moisture");
    let v6 = payload[..payload.len() - 1].to_vec();
    let loaded = decode(&framed(6, &v6)).unwrap();
    assert_eq!(loaded.model.particles.pos, model.particles.pos);
    assert!(!loaded.model.settings.moisture.enabled && loaded.model.particles.moisture.water.is_empty());
    let payload = &payload[..payload.len() - 2];
    let mut v5 = Vec::new();
    v5.extend_from_slice(b"MDEMCKPT");
    v5.extend_from_slice(&5u32.to_le_bytes());
    v5.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    v5.extend_from_slice(payload);
    let crc = crc32fast::hash(&v5);
    v5.extend_from_slice(&crc.to_le_bytes());
    let loaded = decode(&v5).unwrap();
    assert_eq!(loaded.model.particles.pos, model.particles.pos);
    assert_eq!(loaded.model.materials[0].provenance, model.materials[0].provenance);
    assert!(loaded.model.contacts.state.iter().all(|s| s.weakened == 0));
}
