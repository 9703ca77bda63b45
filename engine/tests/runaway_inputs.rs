//! Inputs that would throw the numbers out of a step are refused before the run, naming the
//! cause and the limit, and leave the model as it was: an applied force or torque that alone
//! moves its element more than half its radius in one step, an element or a wall set moving
//! that fast, a centre beyond 1e9 m or a radius below a nanometre. Without the checks each ran
//! into a non-finite element a chunk later (found by tests/robustness.rs in the host), the
//! message blaming dt and the model left holding infinities. Each limit is tested on both
//! sides: just past it refused, just inside it run.

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::guard::{MAX_LENGTH, MIN_RADIUS, RUNAWAY_STEP_FRACTION};
use matdem_engine::{Model, Simulation, Vec3, Wall, WallMotion};

const R: f64 = 1e-3;
const DT: f64 = 1e-6;

/// One free element at the origin, soft, no gravity.
fn free_element() -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, 1.0, 1e7, 0.3)).unwrap();
    m.add_particle(Vec3::zeros(), R, k).unwrap();
    m.set_dt(DT).unwrap();
    m
}

/// Runs one step (a constant load that passes the check still runs a free element away a
/// few steps later, as it should: the guard stops that): the error's text, or None.
fn run(m: Model) -> (Option<String>, Model) {
    let mut sim = Simulation::new(m);
    let outcome = sim.run(1, &RunControl::default(), &mut |_| {});
    (outcome.err().map(|e| e.to_string()), sim.model)
}

fn every_lane_finite(m: &Model) -> bool {
    let p = &m.particles;
    (0..p.len()).all(|i| p.pos[i].iter().chain(p.vel[i].iter()).chain(p.force[i].iter()).all(|c| c.is_finite()))
}

/// The force that moves the free element `share` of its radius in its first step, from rest.
fn force_for(m: &Model, share: f64) -> f64 {
    share * R * m.particles.mass[0] / (DT * DT)
}

#[test]
fn an_applied_force_that_throws_its_element_out_of_a_step_is_refused_naming_the_force() {
    let limit = RUNAWAY_STEP_FRACTION;
    let mut m = free_element();
    let f = force_for(&m, 1.01 * limit);
    m.apply_force(&[0], Vec3::new(0.0, 0.0, f)).unwrap();
    let (err, m) = run(m);
    let err = err.expect("refused");
    assert!(err.contains("the applied force is the cause") && err.contains("element 0"), "{err}");
    assert!(err.contains("d.apply_force") && !err.contains("halve dt"), "{err}");
    // Refused before the first step: nothing moved.
    assert_eq!((m.clock.step, m.particles.pos[0]), (0, Vec3::zeros()));
    // The message's limit: just under it runs.
    let mut m = free_element();
    let f = force_for(&m, 0.99 * limit);
    m.apply_force(&[0], Vec3::new(0.0, 0.0, f)).unwrap();
    let (err, _) = run(m);
    assert_eq!(err, None);
    // 1e300 N (the robustness test's value) ends in the same refusal, not in infinities.
    let mut m = free_element();
    m.apply_force(&[0], Vec3::new(0.0, 0.0, 1e300)).unwrap();
    let (err, m) = run(m);
    assert!(err.unwrap().contains("applied force is the cause"));
    assert!(every_lane_finite(&m));
}

#[test]
fn an_applied_torque_that_turns_its_element_out_of_a_step_is_refused_naming_the_torque() {
    // The surface of a turning element travels α·dt²·r in the first step, α = T/I.
    let mut m = free_element();
    let inertia = m.particles.inertia(0);
    let torque = |share: f64| share * inertia / (DT * DT);
    m.apply_torque(&[0], Vec3::new(torque(1.01 * RUNAWAY_STEP_FRACTION), 0.0, 0.0)).unwrap();
    let (err, _) = run(m);
    let err = err.expect("refused");
    assert!(err.contains("the applied torque is the cause") && err.contains("d.apply_torque"), "{err}");
    let mut m = free_element();
    m.apply_torque(&[0], Vec3::new(torque(0.99 * RUNAWAY_STEP_FRACTION), 0.0, 0.0)).unwrap();
    assert_eq!(run(m).0, None);
}

#[test]
fn an_element_set_faster_than_half_its_radius_a_step_is_refused_before_the_run() {
    let speed = RUNAWAY_STEP_FRACTION * R / DT;
    let mut m = free_element();
    m.particles.vel[0] = Vec3::new(1.01 * speed, 0.0, 0.0);
    let (err, m) = run(m);
    let err = err.expect("refused");
    assert!(err.contains("element 0 moves at") && err.contains("d.set_velocity"), "{err}");
    assert_eq!(m.clock.step, 0);
    let mut m = free_element();
    m.particles.vel[0] = Vec3::new(0.99 * speed, 0.0, 0.0);
    assert_eq!(run(m).0, None);
}

#[test]
fn a_wall_moving_faster_than_half_the_smallest_radius_a_step_is_refused() {
    let speed = RUNAWAY_STEP_FRACTION * R / DT;
    let wall = |v: f64| {
        let mut w = Wall::plane("lid", Vec3::new(0.0, 0.0, 0.01), Vec3::new(0.0, 0.0, -1.0), 1e-4).unwrap();
        w.motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -v));
        w
    };
    let mut m = free_element();
    m.add_wall(wall(1.01 * speed)).unwrap();
    let err = run(m).0.expect("refused");
    assert!(err.contains("wall `lid` moves at") && err.contains("d.move_boundary"), "{err}");
    let mut m = free_element();
    m.add_wall(wall(0.99 * speed)).unwrap();
    assert_eq!(run(m).0, None);
}

#[test]
fn a_centre_beyond_1e9_m_or_a_radius_below_a_nanometre_is_refused_naming_the_element() {
    // A second element far along y (the robustness test's d.x = 1e308 ran a chunk, then
    // stopped on infinities blamed on dt).
    for (y, refused) in [(1.01 * MAX_LENGTH, true), (0.99 * MAX_LENGTH, false), (1e308, true)] {
        let mut m = free_element();
        m.add_particle(Vec3::new(0.0, y, 0.0), R, 0).unwrap();
        let (err, m) = run(m);
        assert_eq!(err.is_some(), refused, "y = {y:e}: {err:?}");
        if let Some(err) = err {
            assert!(err.contains("element 1 lies at y") && err.contains("1e9"), "{err}");
            assert!(every_lane_finite(&m));
        }
    }
    for (r, refused) in [(0.99 * MIN_RADIUS, true), (1.01 * MIN_RADIUS, false), (1e-300, true), (1e308, true)] {
        let mut m = free_element();
        m.set_radii(&[0], &[r]).unwrap();
        // A nanometre grain's own critical step is picoseconds.
        if !refused {
            m.set_standard_dt().unwrap();
        }
        let (err, _) = run(m);
        assert_eq!(err.is_some(), refused, "r = {r:e}: {err:?}");
        if let Some(err) = err {
            assert!(err.contains("element 0 has radius"), "{err}");
        }
    }
}
