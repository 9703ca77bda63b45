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

// Rows built before a particle was added cover the particles that were there (stale, rebuilt
// before the next step reads them): a model saved then loads, and continues bit for bit.
#[test]
fn a_model_saved_after_adding_a_particle_loads_and_continues_bitwise() {
    let mut straight = loaded_sample();
    let top = straight.model.particles.pos.iter().map(|p| p.z).fold(f64::MIN, f64::max);
    straight.model.add_particle(Vec3::new(2e-3, 2e-3, top + 1.2e-3), 0.45e-3, 0).unwrap();
    let bytes = encode(&straight.model, b"");
    assert!(straight.model.contacts.row_start.len() < straight.model.len() + 1, "rows built before the particle");
    run(&mut straight, 200);
    let mut resumed = Simulation::new(decode(&bytes).unwrap().model);
    run(&mut resumed, 200);
    assert!(encode(&straight.model, b"") == encode(&resumed.model, b""), "the resumed model differs");
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
    // Before: a format-1 file was told "this build reads version 8", though it reads 2 to 8.
    bytes[8..12].copy_from_slice(&1u32.to_le_bytes());
    let e = decode(&bytes).unwrap_err();
    assert!(e.to_string().contains(&format!("reads versions 2 to {FORMAT_VERSION}")), "{e}");
}

#[test]
fn a_file_of_another_kind_is_refused_as_not_a_checkpoint() {
    let e = decode(b"step,time\n0,0\n").unwrap_err();
    assert_eq!(e, CheckpointError::NotACheckpoint);
    assert!(e.to_string().contains("d.save"), "{e}");
    assert_eq!(decode(b"").unwrap_err(), CheckpointError::NotACheckpoint);
}

// A model that does not hold together is refused before anything steps it: as corrupt when
// this engine version wrote it (the file was altered after it was written), as incompatible
// when another did (a layout this build may misread).
#[test]
fn a_well_formed_payload_with_inconsistent_lanes_is_refused_not_stepped() {
    let mut m = loaded_sample().model;
    m.particles.radius.pop();
    let bytes = encode(&m, b"");
    let e = decode(&bytes).unwrap_err();
    assert!(matches!(e, CheckpointError::Corrupt { .. }), "{e:?}");
    assert!(e.to_string().contains("particle lanes") && e.to_string().contains("save the model again"), "{e}");
    // The same payload stamped by another writer (the version string leads the payload).
    let writer = matdem_engine::checkpoint::WRITER;
    let payload = &bytes[20..bytes.len() - 4];
    assert_eq!(payload[0] as usize, writer.len());
    let mut other = payload.to_vec();
    other[1..1 + writer.len()].copy_from_slice(&"9".repeat(writer.len()).into_bytes());
    let e = decode(&framed(FORMAT_VERSION, &other)).unwrap_err();
    assert!(matches!(&e, CheckpointError::Incompatible { reason, .. } if reason.contains("particle lanes")), "{e:?}");
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
    watched.observers = vec![Observer {
        every: 37,
        call: Box::new(move |m| {
            log.borrow_mut().push(m.clock.step);
            Ok(())
        }),
    }];
    run(&mut watched, 1000);
    let start = plain.model.clock.step - 1000;
    let expected: Vec<u64> = (start + 1..=start + 1000).filter(|s| s % 37 == 0).collect();
    assert_eq!(*seen.borrow(), expected);
    assert!(encode(&plain.model, b"") == encode(&watched.model, b""), "observing changed the run");
}

/// A loaded sample whose bonds are parallel bonds (rotation on, bonds loaded by gravity).
fn parallel_bonded_sample() -> Simulation {
    use matdem_engine::effects::parallel_bond::physics::ParallelBondParams;
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

// Formats 5 (before joints: the payload ends at the materials' provenance) and 6 (before the
// optional stages' sections: it ends at the bonds' strength shares) still load, with whole
// bonds and no optional stage; made from a format-8 file of a model without joints or optional
// stages, whose payload, less its body work, ends with two empty lists (one byte each). The
// sample's rotation is taken off: its angles would be a section.
#[test]
fn format_5_and_6_checkpoints_still_load() {
    let mut model = loaded_sample().model;
    model.settings.rotation = false;
    model.particles.rotation = None;
    let v8 = encode(&model, b"annex");
    // Format 8's body work ends the payload; without it, format 7's.
    let account = postcard::to_stdvec(&model.body_work).unwrap();
    let payload = &v8[20..v8.len() - 4 - account.len()];
    assert_eq!(&payload[payload.len() - 2..], &[0, 0], "no weakened bonds, no sections");
    for (version, cut) in [(5u32, 2), (6, 1)] {
        let loaded = decode(&framed(version, &payload[..payload.len() - cut])).unwrap();
        assert_eq!(loaded.annex, b"annex");
        assert_eq!(loaded.model.particles.pos, model.particles.pos);
        assert_eq!(loaded.model.materials[0].provenance, model.materials[0].provenance);
        assert!(loaded.model.contacts.state.iter().all(|s| s.weakened == 0));
        assert!(loaded.model.settings.rolling.is_none() && loaded.model.pores.is_none());
    }
    // A payload longer than its format says is refused, not half-read.
    let long = framed(6, payload);
    assert!(matches!(decode(&long), Err(CheckpointError::Incompatible { .. })), "{:?}", decode(&long).err());
}

// Rolling resistance (epsd: each contact's rolling spring is state) travels in format 7's
// sections: saved mid-run, loaded and continued, the model ends bit for bit as the straight run.
#[test]
fn a_model_with_epsd_rolling_resistance_continues_bitwise_after_a_checkpoint() {
    use matdem_engine::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
    let mut straight = loaded_sample();
    straight.model.settings.rolling = Some(RollingResistance::new(RollingModel::Epsd, 0.2, 0.3).unwrap());
    run(&mut straight, 300);
    let bytes = encode(&straight.model, b"");
    run(&mut straight, 500);
    let loaded = decode(&bytes).unwrap().model;
    assert_eq!(loaded.settings.rolling, straight.model.settings.rolling);
    assert!(loaded.contacts.rolling.iter().any(|s| s.norm() > 0.0), "the rolling springs must be loaded");
    let mut resumed = Simulation::new(loaded);
    run(&mut resumed, 500);
    let (a, b) = (&straight.model, &resumed.model);
    assert_eq!(a.particles.pos, b.particles.pos);
    assert_eq!(a.particles.rotation.as_ref().unwrap().ang_vel, b.particles.rotation.as_ref().unwrap().ang_vel);
    assert_eq!(a.contacts.rolling, b.contacts.rolling);
    assert_eq!(a.wall_rolling, b.wall_rolling);
}

/// The loaded sample with pore flow on: a soft fluid (so a few sub-steps a step suffice), a
/// reservoir at 2 kPa in the pores of the bottom layer and the top platen pressing down.
fn pore_flow_sample() -> Simulation {
    use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, PoreRegion};
    let mut sim = loaded_sample();
    let m = &mut sim.model;
    m.settings.pores.fluid = Fluid { bulk_modulus: 1e6, viscosity: 1e-2, max_substeps: 5000, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    let bottom = Vec3::new(-1.0, -1.0, -1.0);
    m.add_pore_boundary(PoreRegion::Box { lo: bottom, hi: Vec3::new(1.0, 1.0, 1.5e-3) }, BoundaryKind::Pressure(2e3))
        .unwrap();
    sim
}

// Pore flow (its network as last built, the fluid's masses, the boundaries) travels in format
// 7's sections: saved mid-run, loaded and continued, the model and its fluid end bit for bit as
// the straight run.
#[test]
fn a_model_with_pore_flow_continues_bitwise_after_a_checkpoint() {
    let mut straight = pore_flow_sample();
    run(&mut straight, 200);
    let bytes = encode(&straight.model, b"");
    run(&mut straight, 300);
    let loaded = decode(&bytes).unwrap().model;
    assert_eq!(loaded.settings.pores, straight.model.settings.pores);
    let mut resumed = Simulation::new(loaded);
    run(&mut resumed, 300);
    let (a, b) = (&straight.model, &resumed.model);
    let (fa, fb) = (a.pores.as_ref().unwrap(), b.pores.as_ref().unwrap());
    assert!(fa.pressure.iter().any(|&p| p > 100.0), "the reservoir must have pushed fluid in");
    assert_eq!(a.particles.pos, b.particles.pos);
    assert_eq!(fa.mass, fb.mass);
    assert_eq!(fa.pressure, fb.pressure);
    assert_eq!(fa.boundary_mass.to_bits(), fb.boundary_mass.to_bits());
    assert_eq!(fa.rebuilds, fb.rebuilds);
}

// A pore network whose indices do not fit the elements (a crafted or mismatched file) is
// refused when it is loaded, not stepped.
#[test]
fn a_pore_network_that_does_not_fit_the_elements_is_refused() {
    let mut model = pore_flow_sample().model;
    let f = model.pores.as_mut().unwrap();
    f.network.tri.tets[0].v[0] = model.particles.pos.len() as u32 + 5;
    match decode(&encode(&model, b"")) {
        Err(CheckpointError::Corrupt { reason }) => assert!(reason.contains("pore network"), "{reason}"),
        other => panic!("expected a refusal, got {:?}", other.map(|_| ())),
    }
}

// The pore fluid's heat (its temperatures, the fluid's thermal properties, per-material
// permeability factors, region temperatures and booked totals) travels in its own format-7
// section after the pore flow's: saved mid-run, loaded and continued, grains and fluid end bit
// for bit as the straight run.
#[test]
fn a_model_with_pore_heat_continues_bitwise_after_a_checkpoint() {
    use matdem_engine::effects::conduction::ThermalProps;
    use matdem_engine::effects::pore_flow::{BoundaryKind, FluidHeat, PoreRegion};
    let mut sim = pore_flow_sample();
    let m = &mut sim.model;
    m.enable_heat();
    m.set_thermal_material("grain", ThermalProps { conductivity: 3.0, specific_heat: 0.8, expansion: 0.0 }).unwrap();
    let mut fluid = m.settings.pores.fluid.clone();
    fluid.heat = FluidHeat { specific_heat: 4.186, expansion: 3e-4, ..FluidHeat::default() };
    fluid.permeability.insert("grain".into(), 0.5);
    m.set_pore_fluid(fluid).unwrap();
    let hot = PoreRegion::Point(Vec3::new(2e-3, 2e-3, 2.5e-3));
    m.add_pore_boundary_at(hot, BoundaryKind::Flux(1e-9), Some(353.15)).unwrap();
    let mut straight = sim;
    run(&mut straight, 200);
    let bytes = encode(&straight.model, b"");
    run(&mut straight, 300);
    let loaded = decode(&bytes).unwrap().model;
    assert_eq!(loaded.settings.pores, straight.model.settings.pores);
    assert_eq!(loaded.settings.pores.fluid.permeability, straight.model.settings.pores.fluid.permeability);
    assert_eq!(loaded.settings.pores.boundaries[1].temperature, Some(353.15));
    let mut resumed = Simulation::new(loaded);
    run(&mut resumed, 300);
    let (a, b) = (&straight.model, &resumed.model);
    let (fa, fb) = (a.pores.as_ref().unwrap(), b.pores.as_ref().unwrap());
    assert!(fa.temperature.iter().any(|&t| t > 293.2), "the hot injection must have warmed a pore");
    assert_eq!(a.particles.pos, b.particles.pos);
    assert_eq!(a.particles.thermal.temperature, b.particles.thermal.temperature);
    assert_eq!(fa.temperature, fb.temperature);
    assert_eq!(fa.mass, fb.mass);
    assert_eq!(fa.region_mass, fb.region_mass);
    assert_eq!(fa.region_heat, fb.region_heat);
}

// Format 7 (before the body work: its payload ends at the sections) still loads, with no body
// work booked and the water table it holds taken as the one the account last saw: a table
// lowered after loading is booked (to 1e-12 of the change of the buoyant potential), as it
// would be in the model that was saved. A format-8 file carries the work booked before it.
#[test]
fn a_format_7_checkpoint_loads_with_no_body_work_and_its_table_as_seen() {
    let mut sim = loaded_sample();
    let top = sim.model.particles.pos.iter().map(|p| p.z).fold(f64::MIN, f64::max);
    sim.model.settings.water.density = 1000.0;
    sim.model.settings.water.level = Some(top);
    run(&mut sim, 50);
    let flooded = sim.model.body_work();
    sim.model.settings.water.level = Some(0.7 * top);
    run(&mut sim, 50);
    let booked = sim.model.body_work();
    assert!(flooded > 0.0 && booked < flooded, "flooding is positive work, lowering negative: {flooded:e}, {booked:e}");
    let v8 = encode(&sim.model, b"annex");
    assert_eq!(decode(&v8).unwrap().model.body_work(), booked);

    let account = postcard::to_stdvec(&sim.model.body_work).unwrap();
    let v7 = framed(7, &v8[20..v8.len() - 4 - account.len()]);
    let mut m = decode(&v7).unwrap().model;
    assert_eq!(m.particles.pos, sim.model.particles.pos);
    assert_eq!(m.body_work(), 0.0, "a format-7 file has no body work");
    let buoyant = |m: &Model| matdem_engine::body_potential::BodyFields::of(m).buoyant_potential(m);
    let high = buoyant(&m);
    m.settings.water.level = Some(0.4 * top);
    let change = buoyant(&m) - high;
    assert!(change < 0.0 && (m.body_work() - change).abs() < 1e-12 * change.abs(), "{} vs {change}", m.body_work());
}

#[test]
fn two_observers_each_see_their_own_steps_and_change_no_result() {
    use matdem_engine::simulation::Observer;
    use std::cell::RefCell;
    use std::rc::Rc;
    let mut plain = loaded_sample();
    run(&mut plain, 400);
    let mut watched = loaded_sample();
    let seen: Rc<RefCell<Vec<(u64, u64)>>> = Rc::default();
    let observer = |every: u64| {
        let log = seen.clone();
        Observer {
            every,
            call: Box::new(move |m| {
                log.borrow_mut().push((every, m.clock.step));
                Ok(())
            }),
        }
    };
    watched.observers = vec![observer(37), observer(50)];
    run(&mut watched, 400);
    let start = plain.model.clock.step - 400;
    let mut expected = Vec::new();
    for s in start + 1..=start + 400 {
        for every in [37, 50] {
            if s % every == 0 {
                expected.push((every, s));
            }
        }
    }
    assert_eq!(*seen.borrow(), expected);
    assert!(encode(&plain.model, b"") == encode(&watched.model, b""), "observing changed the run");
}
