//! The water table in the energy account: the buoyant potential U_b = −g_z·ρ_f·∫V_sub dz
//! (ρ_f·|g|·V times a submerged element's depth; `body_potential`) is part of the mechanical
//! energy, the fluid's drag books its heat in the damping lane, and a change of the table
//! between runs is work done on the model (`Energies::body_work`), so that
//! mechanical + buoyant potential + heat − wall work − body work stays constant.
//!
//! Tolerances are stated against the heat the scene dissipates (the account's content); each
//! test also checks that the buoyant potential is a large share of the account, so that an
//! account without it could not pass.

use crate::common::{material, run};
use matdem_engine::backend::RunControl;
use matdem_engine::state::particles::dof;
use matdem_engine::status::Energies;
use matdem_engine::{Model, Simulation, Vec3, Wall};
use std::f64::consts::PI;

const R: f64 = 1e-3;
const RHO: f64 = 2650.0;
const RHO_F: f64 = 1000.0;
const G: f64 = 9.81;
/// The water's surface in the drop scene (m).
const LEVEL: f64 = 0.02;

/// One element (R = 1 mm) whose bottom is 5 mm above the water (surface at 20 mm), gravity,
/// a fluid of viscosity `mu`, local damping `alpha`, no other damping; with `floor`, a rigid
/// floor at z = 0 (soft: kn 100 N/m, so that the standard step is not tiny), else nothing
/// below (dt 1e-5 s: the drag's x = dt/τ is 1.7e-4).
fn drop_scene(mu: f64, alpha: f64, floor: bool) -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("sand", RHO, 100.0, 1e7, 0.3)).unwrap();
    m.add_particle(Vec3::new(0.0, 0.0, LEVEL + R + 0.005), R, k).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    m.settings.local_damping = alpha;
    m.settings.water =
        matdem_engine::effects::buoyancy::WaterTable { level: Some(LEVEL), density: RHO_F, viscosity: mu };
    if floor {
        m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1e-6).unwrap()).unwrap();
        m.set_standard_dt().unwrap();
    } else {
        m.set_dt(1e-5).unwrap();
    }
    m
}

/// Runs `steps` steps sampling the account every `every`; returns the samples. (A sample's
/// kinetic energy is the integer step's and it holds half the step's heat; `energies()` between
/// runs reads the half-step velocities, a convention half a step away: compare samples.)
fn sampled(sim: &mut Simulation, steps: u64, every: u64) -> Vec<Energies> {
    let mut out = Vec::new();
    sim.run_sampled(steps, every, &RunControl::default(), &mut |_| {}, &mut |s| out.push(s.energies)).unwrap();
    out
}

/// The largest departure of the samples' totals from `start`.
fn drift(samples: &[Energies], start: f64) -> f64 {
    samples.iter().map(|e| (e.total() - start).abs()).fold(0.0, f64::max)
}

// A sphere dropped into water with Stokes drag (μ = 0.01 Pa·s: terminal speed 0.36 m/s,
// τ = 59 ms), no local or viscous damping: it falls 5 mm through air, enters the water (the cap)
// and sinks to its terminal speed, 0.4 s in all (40 000 steps of 1e-5 s). Sampled every 10
// steps, kinetic + gravity + buoyant potential + drag heat stays within 1e-8 of the heat
// dissipated (measured 2.3e-9, the leapfrog's own offset); the heat grows at the rate the drag
// takes at the terminal speed, (m − ρ_f·V)·g·v_t (1e-3), and the buoyant potential is
// ρ_f·g·V times the depth — 0.6 of the heat, so an account without it could not pass.
#[test]
fn a_sphere_dropped_into_water_with_drag_keeps_its_account() {
    let mut sim = Simulation::new(drop_scene(0.01, 0.0, false));
    let start = sim.energies();
    assert_eq!(start.buoyancy, 0.0, "dry at the start");
    let samples = sampled(&mut sim, 40_000, 10);
    let end = *samples.last().unwrap();
    let heat = end.heat_damping;
    let d = drift(&samples, start.total());
    eprintln!(
        "drop with drag: {} samples, drift {d:.3e} J = {:.3e} of the heat {heat:.4e}; end {end:?}",
        samples.len(),
        d / heat
    );
    assert!(d < 1e-8 * heat, "the account moved by {:.3e} of the heat", d / heat);
    let v = 4.0 / 3.0 * PI * R.powi(3);
    let p = &sim.model.particles;
    let (mass, speed) = (p.mass[0], -p.vel[0].z);
    let terminal = 2.0 * (RHO - RHO_F) * G * R * R / (9.0 * 0.01);
    assert!((speed / terminal - 1.0).abs() < 1e-3, "sinks at {speed} m/s, terminal {terminal}");
    // The last sample's height from its gravity energy m·g·z.
    let z = end.gravity / (mass * G);
    let ub = RHO_F * G * v * (LEVEL - z);
    assert!((end.buoyancy - ub).abs() < 1e-9 * ub, "buoyant potential {} vs {ub}", end.buoyancy);
    assert!(end.buoyancy > 0.3 * heat, "the buoyant potential must weigh in the account");
    // The drag's heat rate at the terminal speed: the buoyant weight times the speed.
    let more = sampled(&mut sim, 1000, 1000);
    let rate = (more[0].heat_damping - heat) / (10.0 * sim.model.clock.dt);
    let expected = (mass - RHO_F * v) * G * terminal;
    assert!((rate / expected - 1.0).abs() < 1e-3, "heat rate {rate:e} W, expected {expected:e}");
    assert_eq!(end.body_work, 0.0, "nothing moved the table");
}

// The same drop onto a floor (soft, kn 100 N/m; standard step): the sphere bounces and comes to
// rest in the water. The account is within 1e-3 of the heat (measured 3.9e-4): during each
// bounce the leapfrog's kinetic energy at the integer step and the spring's energy differ by
// the contact's (ω·dt)²/8 ≈ 4e-3 of the impact's energy, and a little of that stays with each
// bounce (the leapfrog's impact is not exactly elastic at 1/50 of the contact's period), none of
// it the drag's: at the end, nearly at rest, the account is within 1e-4 of the heat (measured
// 3.7e-5).
#[test]
fn a_sphere_dropped_onto_the_floor_of_a_pool_keeps_its_account_at_rest() {
    let mut sim = Simulation::new(drop_scene(0.01, 0.0, true));
    let start = sim.energies();
    let steps = (1.0 / sim.model.clock.dt) as u64;
    let samples = sampled(&mut sim, steps, 10);
    let end = *samples.last().unwrap();
    let heat = end.heat_damping;
    let d = drift(&samples, start.total());
    let d_end = (end.total() - start.total()).abs();
    eprintln!(
        "drop on a floor: drift {:.3e}, at the end {:.3e} of the heat {heat:.4e}; end {end:?}",
        d / heat,
        d_end / heat
    );
    assert!(end.kinetic < 1e-5 * heat, "nearly at rest: kinetic {:e}", end.kinetic);
    assert!(end.normal_elastic > 0.0, "resting on the floor");
    assert!(d < 1e-3 * heat, "the account moved by {:.3e} of the heat", d / heat);
    assert!(d_end < 1e-4 * heat, "at the end the account is off by {:.3e} of the heat", d_end / heat);
}

// With local damping (α = 0.3) as well, the drag's heat is computed before local damping acts
// (the velocity the kick would reach without it), and local damping books −F_d·v_{n−½}·dt
// (integrate.rs): the account is looser, within 1e-4 of the heat (measured 9.8e-6).
#[test]
fn with_local_damping_too_the_account_closes_to_the_stated_tolerance() {
    let mut sim = Simulation::new(drop_scene(0.01, 0.3, false));
    let start = sim.energies();
    let samples = sampled(&mut sim, 25_000, 10);
    let heat = samples.last().unwrap().heat_damping;
    let d = drift(&samples, start.total());
    eprintln!("drop with drag and local damping: drift {:.3e} of the heat {heat:.4e}", d / heat);
    assert!(d < 1e-4 * heat, "the account moved by {:.3e} of the heat", d / heat);
}

/// Five elements stacked on a floor (soft springs, so that the load the table adds settles
/// them visibly), held to the vertical, MatDEM's viscous damping.
fn column(level: f64) -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("sand", RHO, 20.0, 1e7, 0.3)).unwrap();
    for i in 0..5 {
        m.add_particle(Vec3::new(0.0, 0.0, R + 2.0 * R * i as f64), R, k).unwrap();
    }
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1e-6).unwrap()).unwrap();
    let all: Vec<u32> = (0..5).collect();
    m.fix(&all, dof::X | dof::Y, true).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -G);
    m.settings.damping = 0.3;
    m.settings.water.density = RHO_F;
    m.settings.water.level = Some(level);
    m.set_standard_dt().unwrap();
    m
}

/// The buoyant potential of elements at heights `z` under `level`, written out: ρ_f·g·V·depth
/// submerged, ρ_f·g·π·(r·h³/3 − h⁴/12) for a cap of height h, nothing dry.
fn expected_potential(z: &[f64], level: f64) -> f64 {
    z.iter()
        .map(|&z| {
            let h = level + R - z;
            RHO_F
                * G
                * if h <= 0.0 {
                    0.0
                } else if h < 2.0 * R {
                    PI * (R * h.powi(3) / 3.0 - h.powi(4) / 12.0)
                } else {
                    4.0 / 3.0 * PI * R.powi(3) * (level - z)
                }
        })
        .sum()
}

// The table lowered in a step. A submerged column (level 2 mm above its top) settles; the
// level is set to the centre of the third element between runs: the body work booked is the
// change of the buoyant potential where the elements stood (written out: three elements
// submerged by less, the third half, two dry; to 1e-12), and as the column settles under the
// lost buoyancy the account, back at rest, is within 1e-9 of the heat that settling released
// (measured 2e-12; while it moves, within 1e-3, measured 2.2e-4: the leapfrog's contact
// energy at 1/50 of a period). Raising the table back books the opposite work.
#[test]
fn lowering_the_table_books_its_work_and_the_account_closes_as_the_ground_settles() {
    let top = 10.0 * R;
    let mut sim = Simulation::new(column(top + 2.0 * R));
    run(&mut sim, 40_000).unwrap();
    let settled = sim.energies();
    assert!(settled.kinetic < 1e-20, "settled: kinetic {:e}", settled.kinetic);
    let z: Vec<f64> = sim.model.particles.pos.iter().map(|p| p.z).collect();
    assert!((settled.buoyancy - expected_potential(&z, top + 2.0 * R)).abs() < 1e-12 * settled.buoyancy);

    let low = z[2];
    sim.model.settings.water.level = Some(low);
    let lowered = sim.energies();
    let work = expected_potential(&z, low) - expected_potential(&z, top + 2.0 * R);
    eprintln!("lowered: body work {:.6e}, expected {work:.6e}", lowered.body_work);
    assert!(work < 0.0);
    assert!((lowered.body_work - work).abs() < 1e-12 * work.abs(), "body work {} vs {work}", lowered.body_work);
    assert!((lowered.total() - settled.total()).abs() < 1e-12 * work.abs(), "the change itself keeps the total");

    let samples = sampled(&mut sim, 40_000, 50);
    let end = *samples.last().unwrap();
    let heat = end.heat() - lowered.heat();
    let d = drift(&samples, lowered.total());
    let d_end = (end.total() - lowered.total()).abs();
    eprintln!("settling: heat {heat:.4e}, drift {:.3e} of it, at rest {:.3e}; end {end:?}", d / heat, d_end / heat);
    let settle = z[4] - sim.model.particles.pos[4].z;
    assert!(settle > 0.0 && heat > 0.0, "the column settles under the lost buoyancy: {settle:e} m");
    assert!(end.kinetic < 1e-12 * heat, "at rest: kinetic {:e}", end.kinetic);
    assert!(d_end < 1e-9 * heat, "at rest the account is off by {:.3e} of the settling's heat", d_end / heat);
    assert!(d < 1e-3 * heat, "the account moved by {:.3e} of the settling's heat", d / heat);
    assert!(end.body_work == lowered.body_work, "one change, booked once");

    // Raised back: the opposite change, at the settled positions.
    let z: Vec<f64> = sim.model.particles.pos.iter().map(|p| p.z).collect();
    let before = sim.model.body_work.work;
    sim.model.settings.water.level = Some(top + 2.0 * R);
    run(&mut sim, 1).unwrap();
    let raised = expected_potential(&z, top + 2.0 * R) - expected_potential(&z, low);
    let booked = sim.model.body_work.work - before;
    assert!(raised > 0.0 && (booked - raised).abs() < 1e-12 * raised, "raising books {booked} vs {raised}");
}

// The body work in a checkpoint (format 8). The column's table lowered as above; 10 000 steps
// into the settling the model is saved, and the uninterrupted run and the loaded one go on for
// 30 000 steps each: the loaded model continues bit for bit (its samples, positions and the
// whole encoding, body work included) and its account, against the total at the change, closes
// as the uninterrupted one's does — within 1e-3 of the settling's heat while it moves and 1e-9
// at rest (the same tolerances as above; measured 2.2e-4 for both, and 2e-12). The body work
// booked is −1 400 times that heat, so a loaded model that had lost it (formats 2 to 7) would
// be off by all of it.
#[test]
fn a_loaded_model_keeps_the_body_work_of_a_lowered_table_and_its_account_closes() {
    use matdem_engine::checkpoint::{decode, encode};
    let top = 10.0 * R;
    let mut straight = Simulation::new(column(top + 2.0 * R));
    run(&mut straight, 40_000).unwrap();
    straight.model.settings.water.level = Some(straight.model.particles.pos[2].z);
    let lowered = straight.energies();
    let before = sampled(&mut straight, 10_000, 50);
    let bytes = encode(&straight.model, b"");
    let after = sampled(&mut straight, 30_000, 50);

    let loaded = decode(&bytes).unwrap().model;
    assert_eq!(loaded.body_work, straight.model.body_work, "the booked work and the fields seen travel");
    let mut resumed = Simulation::new(loaded);
    let resumed_samples = sampled(&mut resumed, 30_000, 50);
    let totals = |s: &[Energies]| s.iter().map(|e| e.total().to_bits()).collect::<Vec<_>>();
    assert_eq!(totals(&resumed_samples), totals(&after), "the loaded account's samples differ");
    assert_eq!(straight.model.particles.pos, resumed.model.particles.pos);
    assert!(encode(&straight.model, b"") == encode(&resumed.model, b""), "the resumed model differs");

    let end = *resumed_samples.last().unwrap();
    let heat = end.heat() - lowered.heat();
    let d_straight = drift(&before, lowered.total()).max(drift(&after, lowered.total()));
    let d = drift(&before, lowered.total()).max(drift(&resumed_samples, lowered.total()));
    let d_end = (end.total() - lowered.total()).abs();
    eprintln!(
        "checkpointed settling: body work {:.4e}, heat {heat:.4e}; drift {:.3e} (uninterrupted {:.3e}), at rest {:.3e}",
        end.body_work,
        d / heat,
        d_straight / heat,
        d_end / heat
    );
    assert!(end.body_work < -100.0 * heat, "the body work must weigh in the account: {:e}", end.body_work);
    assert!(end.kinetic < 1e-12 * heat, "at rest: kinetic {:e}", end.kinetic);
    assert!(d < 1e-3 * heat, "the loaded account moved by {:.3e} of the settling's heat", d / heat);
    assert!(d_end < 1e-9 * heat, "at rest the loaded account is off by {:.3e} of the heat", d_end / heat);
}

// Changing gravity between runs is body work too (gravity's potential and the buoyant one where
// the elements stand), and removing the water takes its potential away as work.
#[test]
fn changing_gravity_or_removing_the_water_is_body_work() {
    let mut sim = Simulation::new(column(20.0 * R));
    run(&mut sim, 10).unwrap();
    let before = sim.energies();
    sim.model.settings.gravity = Vec3::new(0.0, 0.0, -1.2 * G);
    let after = sim.energies();
    let w = after.body_work - before.body_work;
    let expected = 0.2 * (before.gravity + before.buoyancy);
    assert!((w - expected).abs() < 1e-12 * expected.abs(), "gravity's change books {w} vs {expected}");
    run(&mut sim, 10).unwrap();
    let e = sim.energies();
    sim.model.settings.water.level = None;
    let dry = sim.energies();
    assert_eq!(dry.buoyancy, 0.0);
    assert!(
        (dry.body_work - e.body_work + e.buoyancy).abs() < 1e-12 * e.buoyancy,
        "the water's potential taken as work"
    );
    assert!((dry.total() - e.total()).abs() < 1e-12 * e.buoyancy);
}

// The GPU backend (f32, lavapipe): the dropped sphere's account, sampled every 500 steps over
// four runs (the device's ledger folded in at each download), within 1e-4 of the heat (f32
// state and heat; measured 3.2e-5), and its drag heat within 2e-4 of the CPU's (measured 2.2e-5).
#[cfg(feature = "gpu")]
#[test]
fn on_the_gpu_the_dropped_sphere_keeps_its_account_and_books_the_cpus_drag_heat() {
    let Some(ctx) = crate::common::gpu("buoyancy_energy") else { return };
    let model = drop_scene(0.01, 0.0, false);
    let mut cpu = Simulation::new(model.clone());
    let mut gpu = Simulation::with_gpu(model, ctx);
    let start = gpu.energies().total();
    let c = *sampled(&mut cpu, 25_000, 25_000 - 1).last().unwrap();
    let mut samples = Vec::new();
    for _ in 0..4 {
        samples.extend(sampled(&mut gpu, 6_250, 500));
    }
    samples.extend(sampled(&mut gpu, 1, 1));
    let g = *samples.last().unwrap();
    let d = drift(&samples, start);
    let rel = (g.heat_damping - c.heat_damping) / c.heat_damping;
    eprintln!(
        "gpu: drift {:.3e} of the heat; drag heat gpu {:.6e}, cpu {:.6e} ({rel:.2e})",
        d / g.heat_damping,
        g.heat_damping,
        c.heat_damping
    );
    assert!(g.heat_damping > 0.0 && g.buoyancy > 0.3 * g.heat_damping);
    assert!(d < 1e-4 * g.heat_damping, "the GPU's account moved by {:.3e} of the heat", d / g.heat_damping);
    assert!(rel.abs() < 2e-4, "GPU drag heat {:e} vs CPU {:e}", g.heat_damping, c.heat_damping);
}
