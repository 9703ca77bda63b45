//! Contact laws through the full engine (model → plan → CPU backend → guard), checked
//! against closed-form answers: Hertz impacts of Chung & Ooi (2011) tests 1–3, the linear
//! spring–dashpot, a static column, MatDEM's bonded contact (tension, shear, friction),
//! determinism across thread counts and the stability guard.
//!
//! Reference: /work/shared/reference/physics.md (§1 Hertz and the Chung & Ooi table, §2
//! linear spring–dashpot table and static checks). Expected values are computed from the
//! formulas; the tables are only used to check those formulas. Run with
//! `cargo test -p matdem-engine --release --test contact_laws -- --nocapture` to see the
//! measured values.

use crate::common::*;
use matdem_engine::builder::Rng;
use matdem_engine::physics::contact_law::BreakKind;
use matdem_engine::state::particles::dof;
use matdem_engine::{Error, Material, Model, NormalKind, Simulation, Vec3, Wall};

/// Steps per contact duration in the impact tests (dt ≈ t_c/2000).
const STEPS_PER_CONTACT: f64 = 2000.0;

/// Steps of free flight before contact. Not a whole number, so that contact starts in the
/// middle of a step and round-off cannot decide whether the first contact step has a
/// dashpot (an explicit dashpot's entry impulse is c·v·dt, an O(dt) effect).
const APPROACH_STEPS: f64 = 50.5;

/// A row of the Chung & Ooi table (physics.md §1): δmax, Fmax, t_c.
struct Table {
    delta_max: f64,
    f_max: f64,
    t_c: f64,
}

/// The formulas must give the table to its 6 significant digits.
fn check_formula_against_table(expected: &HertzImpact, table: &Table) {
    assert!(rel(expected.delta_max, table.delta_max) < 1e-5, "δmax formula {:e}", expected.delta_max);
    assert!(rel(expected.f_max, table.f_max) < 1e-5, "Fmax formula {:e}", expected.f_max);
    assert!(rel(expected.t_c, table.t_c) < 1e-5, "t_c formula {:e}", expected.t_c);
}

/// Runs a Hertz impact scene and checks δmax, Fmax, t_c within 1% and, the contact being
/// elastic, a rebound at the approach speed within 1%.
fn check_hertz_impact(name: &str, mut model: Model, expected: &HertzImpact, probe: fn(&Model) -> Probe) {
    let dt = expected.t_c / STEPS_PER_CONTACT;
    model.set_dt(dt).unwrap();
    let mut sim = Simulation::new(model);
    let imp = run_impact(&mut sim, 3 * STEPS_PER_CONTACT as u64, probe);
    let t_c = imp.duration();
    eprintln!(
        "{name}: δmax {:.6e} (expected {:.6e}, {:+.2e}), Fmax {:.6e} ({:.6e}, {:+.2e}), \
         t_c {:.6e} ({:.6e}, {:+.2e}), e {:.6}",
        imp.max_overlap,
        expected.delta_max,
        imp.max_overlap / expected.delta_max - 1.0,
        imp.peak_force,
        expected.f_max,
        imp.peak_force / expected.f_max - 1.0,
        t_c,
        expected.t_c,
        t_c / expected.t_c - 1.0,
        imp.restitution()
    );
    assert!(rel(imp.max_overlap, expected.delta_max) < 0.01, "{name}: δmax");
    assert!(rel(imp.peak_force, expected.f_max) < 0.01, "{name}: Fmax");
    assert!(rel(t_c, expected.t_c) < 0.01, "{name}: contact duration");
    assert!(rel(imp.restitution(), 1.0) < 0.01, "{name}: elastic rebound");
}

/// Two equal spheres, each at 10 m/s towards the other (relative speed 20 m/s).
fn hertz_two_spheres(name: &str, young: f64, poisson: f64, density: f64, table: Table) {
    let (r, speed) = (0.010, 10.0);
    let expected = HertzImpact::two_spheres(young, poisson, density, r, speed);
    check_formula_against_table(&expected, &table);
    let gap = 2.0 * speed * APPROACH_STEPS * expected.t_c / STEPS_PER_CONTACT;
    let model = two_spheres(material(name, density, 1e6, young, poisson), r, gap, speed, NormalKind::Hertz);
    check_hertz_impact(name, model, &expected, probe_pair);
}

/// A sphere on a rigid plane wall: E* = E/(1 − ν²), R* = R, m* = m.
fn hertz_sphere_on_wall(name: &str, young: f64, poisson: f64, density: f64, r: f64, speed: f64, table: Table) {
    let expected = HertzImpact::sphere_on_wall(young, poisson, density, r, speed);
    check_formula_against_table(&expected, &table);
    let gap = speed * APPROACH_STEPS * expected.t_c / STEPS_PER_CONTACT;
    let model = sphere_on_plane(material(name, density, 1e6, young, poisson), r, gap, speed, NormalKind::Hertz);
    check_hertz_impact(name, model, &expected, probe_wall);
}

// Chung & Ooi test 1, glass (physics.md §1 table). Tolerance 1% on δmax, Fmax, t_c.
#[test]
fn hertz_impact_matches_chung_ooi_test1_glass() {
    let table = Table { delta_max: 2.74113e-4, f_max: 1.06969e4, t_c: 4.03395e-5 };
    hertz_two_spheres("glass", 4.8e10, 0.20, 2800.0, table);
}

// Chung & Ooi test 1, limestone (physics.md §1 table). Tolerance 1% on δmax, Fmax, t_c.
#[test]
fn hertz_impact_matches_chung_ooi_test1_limestone() {
    let table = Table { delta_max: 3.68304e-4, f_max: 7.10824e3, t_c: 5.42010e-5 };
    hertz_two_spheres("limestone", 2.0e10, 0.25, 2500.0, table);
}

// Chung & Ooi test 2, aluminium alloy sphere on a rigid wall (physics.md §1 table).
// Tolerance 1% on δmax, Fmax, t_c.
#[test]
fn hertz_wall_impact_matches_chung_ooi_test2_al_alloy() {
    let table = Table { delta_max: 4.97172e-5, f_max: 1.13699e4, t_c: 7.31657e-4 };
    hertz_sphere_on_wall("al_alloy", 7.0e10, 0.30, 2699.0, 0.10, 0.2, table);
}

// Chung & Ooi test 2, magnesium alloy sphere on a rigid wall (physics.md §1 table).
// Tolerance 1% on δmax, Fmax, t_c.
#[test]
fn hertz_wall_impact_matches_chung_ooi_test2_mg_alloy() {
    let table = Table { delta_max: 5.21233e-5, f_max: 7.23268e3, t_c: 7.67066e-4 };
    hertz_sphere_on_wall("mg_alloy", 4.0e10, 0.35, 1800.0, 0.10, 0.2, table);
}

// Chung & Ooi test 3, aluminium oxide sphere on a rigid wall (physics.md §1 table).
// Tolerance 1% on δmax, Fmax, t_c.
#[test]
fn hertz_wall_impact_matches_chung_ooi_test3_al_oxide() {
    let table = Table { delta_max: 8.08881e-6, f_max: 615.352, t_c: 6.10451e-6 };
    hertz_sphere_on_wall("al_oxide", 3.8e11, 0.23, 4000.0, 0.0025, 3.9, table);
}

// Chung & Ooi test 3, cast iron sphere on a rigid wall (physics.md §1 table).
// Tolerance 1% on δmax, Fmax, t_c.
#[test]
fn hertz_wall_impact_matches_chung_ooi_test3_cast_iron() {
    let table = Table { delta_max: 1.71887e-5, f_max: 506.760, t_c: 1.29721e-5 };
    hertz_sphere_on_wall("cast_iron", 1.0e11, 0.25, 7000.0, 0.0025, 3.9, table);
}

// Chung & Ooi test 3 (physics.md §1: "the measured restitution −v'n/vn equal the requested
// e for e in 0…1"): aluminium oxide and cast iron spheres at 3.9 m/s on a rigid wall, with
// the Hertz dashpot set from material.restitution. Tolerance: 1% on −v_out/v_in for
// e = 0.1 … 1.0; for e = 0 the sphere must not leave the wall with positive speed within
// 5 elastic contact durations.
#[test]
fn hertz_restitution_matches_requested_e_chung_ooi_test3() {
    let (r, speed) = (0.0025, 3.9);
    for (name, young, poisson, density) in [("al_oxide", 3.8e11, 0.23, 4000.0), ("cast_iron", 1.0e11, 0.25, 7000.0)] {
        let elastic = HertzImpact::sphere_on_wall(young, poisson, density, r, speed);
        let dt = elastic.t_c / STEPS_PER_CONTACT;
        let gap = speed * APPROACH_STEPS * dt;
        let scene = |e: f64| {
            let mut mat = material(name, density, 1e6, young, poisson);
            mat.restitution = e;
            let mut m = sphere_on_plane(mat, r, gap, speed, NormalKind::Hertz);
            m.set_dt(dt).unwrap();
            Simulation::new(m)
        };
        for k in 1..=10 {
            let e = k as f64 / 10.0;
            let mut sim = scene(e);
            let imp = run_impact(&mut sim, 10 * STEPS_PER_CONTACT as u64, probe_wall);
            let measured = imp.restitution();
            eprintln!(
                "{name}: requested e {e:.1}, measured {measured:.6} ({:+.2e}), t_c/t_c,elastic {:.4}",
                measured / e - 1.0,
                imp.duration() / elastic.t_c
            );
            assert!(rel(measured, e) < 0.01, "{name}: e = {e}: measured {measured}");
        }
        // e = 0: follow the sphere for 5 elastic contact durations after it first touches.
        let mut sim = scene(0.0);
        let first = probe_wall(&sim.model);
        let mut touched = false;
        let mut left_with = None;
        let mut max_overlap = 0.0f64;
        let mut steps_in_contact = 0;
        while steps_in_contact < 5 * STEPS_PER_CONTACT as u64 {
            run(&mut sim, 1).unwrap();
            let s = probe_wall(&sim.model);
            touched |= s.overlap > 0.0;
            if touched {
                steps_in_contact += 1;
                max_overlap = max_overlap.max(s.overlap);
                if s.overlap <= 0.0 && s.approach < 0.0 {
                    left_with = Some(-s.approach);
                    break;
                }
            }
        }
        let last = probe_wall(&sim.model);
        eprintln!(
            "{name}: requested e 0: after 5 t_c overlap {:.3e} m ({:.2e} of δmax), speed {:+.3e} m/s (v_in {})",
            last.overlap,
            last.overlap / max_overlap,
            -last.approach,
            first.approach
        );
        assert!(left_with.is_none(), "{name}: e = 0 rebounded at {left_with:?} m/s");
    }
}

/// The linear spring–dashpot case of physics.md §2: k = 1e6 N/m, m* = 1e-3 kg, v = 1 m/s.
const LINEAR_K: f64 = 1e6;
const LINEAR_M_STAR: f64 = 1e-3;
const LINEAR_V: f64 = 1.0;

/// Measures one linear impact, either between two identical spheres (pair spring = the
/// material's kn, m* = m/2) or of one sphere on a rigid wall (the wall meets the element's
/// own spring 2·kn, m* = m), and checks it against §2 within 1%.
fn check_linear_impact(e: f64, on_wall: bool) {
    let r = 0.01;
    let expected = LinearImpact::new(LINEAR_K, LINEAR_M_STAR, LINEAR_V, e);
    // physics.md §2 table, to its printed digits.
    let (zeta, c, t_c, delta_max) = match e {
        1.0 => (0.0, 0.0, 9.934588e-5, 3.16228e-5),
        0.7 => (0.112808, 7.134633, 9.998411e-5, 2.67993e-5),
        _ => (0.357857, 22.632872, 1.063915e-4, 1.99284e-5),
    };
    assert!((expected.zeta - zeta).abs() < 1e-6 && (expected.c - c).abs() < 1e-5 && rel(expected.t_c, t_c) < 1e-6);
    assert!(rel(expected.delta_max, delta_max) < 1e-5 && rel(expected.delta_max_undamped, 3.16228e-5) < 1e-5);

    let dt = expected.t_c / STEPS_PER_CONTACT;
    let (kn, mass) = if on_wall { (LINEAR_K / 2.0, LINEAR_M_STAR) } else { (LINEAR_K, 2.0 * LINEAR_M_STAR) };
    let mut mat = material("linear", density_for_mass(mass, r), kn, 1e9, 0.0);
    mat.restitution = e;
    let mut model = if on_wall {
        sphere_on_plane(mat, r, APPROACH_STEPS * LINEAR_V * dt, LINEAR_V, NormalKind::Linear)
    } else {
        two_spheres(mat, r, APPROACH_STEPS * LINEAR_V * dt, LINEAR_V / 2.0, NormalKind::Linear)
    };
    assert!(rel(model.particles.mass[0], mass) < 1e-12);
    model.set_dt(dt).unwrap();
    let mut sim = Simulation::new(model);
    let imp = run_impact(&mut sim, 3 * STEPS_PER_CONTACT as u64, if on_wall { probe_wall } else { probe_pair });
    let where_ = if on_wall { "wall" } else { "pair" };
    eprintln!(
        "linear {where_} e {e}: t_c {:.6e} (expected {:.6e}, {:+.2e}), e {:.6} ({:+.2e}), \
         δmax {:.6e} ({:.6e}, {:+.2e}), Fmax {:.6e}",
        imp.duration(),
        expected.t_c,
        imp.duration() / expected.t_c - 1.0,
        imp.restitution(),
        imp.restitution() / e - 1.0,
        imp.max_overlap,
        expected.delta_max,
        imp.max_overlap / expected.delta_max - 1.0,
        imp.peak_force
    );
    assert!(rel(imp.duration(), expected.t_c) < 0.01, "{where_} e = {e}: contact duration");
    assert!(rel(imp.restitution(), e) < 0.01, "{where_} e = {e}: restitution");
    assert!(rel(imp.max_overlap, expected.delta_max) < 0.01, "{where_} e = {e}: δmax");
    if e == 1.0 {
        assert_eq!(expected.delta_max, expected.delta_max_undamped);
        let f_max = LINEAR_V * (LINEAR_K * LINEAR_M_STAR).sqrt();
        assert!(rel(imp.peak_force, f_max) < 0.01, "{where_}: Fmax {} vs {f_max}", imp.peak_force);
    }
}

// Linear spring–dashpot, physics.md §2 (k = 1e6 N/m, m* = 1e-3 kg, v = 1 m/s, e = 1, 0.7,
// 0.3): contact duration π/ωd, restitution and δmax (the table's column) within 1%, and
// for e = 1 δmax = v·√(m*/k), Fmax = v·√(k·m*) within 1%. Two spheres of mass 2e-3 kg with kn = k.
#[test]
fn linear_pair_impact_matches_spring_dashpot_table() {
    for e in [1.0, 0.7, 0.3] {
        check_linear_impact(e, false);
    }
}

// As above for one sphere of mass 1e-3 kg on a rigid wall; the wall meets the element's
// own spring 2·kn, so kn = k/2. Tolerance 1%.
#[test]
fn linear_wall_impact_matches_spring_dashpot_table() {
    for e in [1.0, 0.7, 0.3] {
        check_linear_impact(e, true);
    }
}

// physics.md §2 static checks: "in a vertical column of identical spheres the i-th contact
// from the top carries i·m·g". Ten spheres on a plane under gravity, settled with MatDEM's
// global viscous damping; each contact force is computed from its overlap with the linear
// law (pair Kn = the material's kn, two identical elements in series; the wall meets the
// element's own spring 2·kn). Tolerance: 1e-6 relative.
#[test]
fn column_of_ten_spheres_carries_i_m_g() {
    let (r, density, kn, g) = (0.01, 2650.0, 1e5, 9.81);
    let n = 10;
    let mut model = Model::new();
    model.settings.gravity = Vec3::new(0.0, 0.0, -g);
    // Heavy damping: half of each element's critical damping (the column's slow modes are
    // then over-damped, and the residual error falls ~5× per 1000 steps).
    model.settings.damping = 0.5;
    let k = model.add_material(material("column", density, kn, 1e9, 0.0)).unwrap();
    model.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
    for i in 0..n {
        model.add_particle(Vec3::new(0.0, 0.0, r + 2.0 * r * i as f64), r, k).unwrap();
    }
    model.set_standard_dt().unwrap();
    let m = sphere_mass(density, r);
    let mut sim = Simulation::new(model);
    // Force carried by each contact, counted from the top (index 0 = contact 1).
    let contact_forces = |model: &Model| -> Vec<f64> {
        let z = |i: usize| model.particles.pos[i].z;
        let mut f: Vec<f64> = (1..n).rev().map(|i| kn * (2.0 * r - (z(i) - z(i - 1)))).collect();
        f.push(2.0 * kn * (r - z(0)));
        f
    };
    run(&mut sim, 30_000).unwrap();
    let max_speed = sim.model.particles.vel.iter().map(|v| v.norm()).fold(0.0, f64::max);
    eprintln!("column: max speed after 30000 steps {max_speed:.2e} m/s");
    assert!(max_speed < 1e-12, "the column is not at rest: {max_speed} m/s");
    let forces = contact_forces(&sim.model);
    for (i, f) in forces.iter().enumerate() {
        let expected = (i + 1) as f64 * m * g;
        eprintln!(
            "column contact {} from the top: {f:.9e} N, expected {expected:.9e} ({:+.2e})",
            i + 1,
            f / expected - 1.0
        );
        assert!(rel(*f, expected) < 1e-6, "contact {}: {f} vs {expected}", i + 1);
    }
    // The engine's own account of the load on the floor agrees.
    let floor = sim.model.walls[0].normal_force;
    assert!(rel(floor, n as f64 * m * g) < 1e-6, "floor load {floor}");
}

/// MatDEM's bonded element pair (paper 003 §2, as in physics/contact_law.rs): Kn = 1e6 N/m,
/// Ks = 1e6 N/m, Xb = 1e-5 m (breaking force Kn·Xb = 10 N), Fs0 = 5 N, μp = 0.5. Two
/// identical elements in series give back the material's kn and ks.
fn bond_material() -> Material {
    let mut mat = material("rock", 2650.0, 1e6, 1e9, 0.0);
    mat.ks = 1e6;
    mat.xb = 1e-5;
    mat.fs0 = 5.0;
    mat.mu_p = 0.5;
    mat
}

const BOND_R: f64 = 0.01;
const BOND_DT: f64 = 1e-6;

/// Two touching spheres (overlap `overlap`), bonded, both fixed so that their velocities are
/// prescribed: particle 0 moves at `v0`, particle 1 at `v1`.
fn bonded_pair(overlap: f64, v0: Vec3, v1: Vec3) -> Simulation {
    prescribed_pair(bond_material(), true, overlap, v0, v1)
}

/// As [`bonded_pair`], for any material, bonded or not.
fn prescribed_pair(mat: Material, bonded: bool, overlap: f64, v0: Vec3, v1: Vec3) -> Simulation {
    let mut model = two_spheres(mat, BOND_R, -overlap, 0.0, NormalKind::Linear);
    if bonded {
        assert_eq!(model.connect(None, 1e-9).unwrap(), 1, "one bond between the touching pair");
    }
    model.fix(&[0, 1], dof::ALL, true).unwrap();
    model.particles.vel[0] = v0;
    model.particles.vel[1] = v1;
    model.set_dt(BOND_DT).unwrap();
    assert!(BOND_DT < model.critical_dt().unwrap().1);
    Simulation::new(model)
}

// Bonding a model whose rows were never built keeps the usual skin (skin_ratio × mean radius):
// a skin of the bonding tolerance (1e-9 m) would rebuild the rows at every step.
#[test]
fn connecting_a_fresh_model_keeps_the_usual_skin() {
    let mut model = two_spheres(bond_material(), BOND_R, -1e-6, 0.0, NormalKind::Linear);
    assert_eq!(model.contacts.skin, 0.0, "a fresh model has no rows yet");
    model.connect(None, 1e-9).unwrap();
    let usual = model.settings.skin_ratio * model.mean_radius();
    assert!(usual > 1e-6 && model.contacts.skin == usual, "skin {} instead of {usual}", model.contacts.skin);
}

// Tension (paper 003 §2; physics.md §3 uses Kn·Xb as the bond strength): two bonded spheres
// pulled apart at 5 mm/s each (relative 1e-8 m per step = 1e-3·Xb). The largest tensile
// force equals Kn·Xb within 1%; a Tension breakage of pair (0, 1) is recorded at
// t = Xb/(2v) within two steps, after which no force remains.
#[test]
fn bonded_pair_pulled_apart_breaks_at_kn_xb() {
    let mat = bond_material();
    let (kn, xb) = (mat.kn, mat.xb);
    let v = 5e-3;
    let mut sim = bonded_pair(0.0, Vec3::new(-v, 0.0, 0.0), Vec3::new(v, 0.0, 0.0));
    let mut max_tension = 0.0f64;
    for _ in 0..1200 {
        run(&mut sim, 1).unwrap();
        // The bond pulls particle 0 towards particle 1 (+x).
        max_tension = max_tension.max(sim.model.particles.force[0].x);
    }
    let expected = kn * xb;
    let b = *sim.model.breakages.first().expect("the bond must break");
    let t_expected = xb / (2.0 * v);
    eprintln!(
        "tension: peak {max_tension:.6} N (expected Kn·Xb = {expected:.6} N, {:+.2e}); broke at t = {:.6e} s, \
         step {} (expected {t_expected:.6e} s)",
        max_tension / expected - 1.0,
        b.time,
        b.step
    );
    assert!(rel(max_tension, expected) < 0.01, "peak tension {max_tension}");
    assert_eq!(sim.model.breakages.len(), 1);
    assert_eq!((b.i, b.j, b.kind), (0, 1, BreakKind::Tension));
    assert!((b.time - t_expected).abs() <= 2.0 * BOND_DT, "break time {}", b.time);
    assert!((b.time - b.step as f64 * BOND_DT).abs() < 1e-12);
    assert_eq!(sim.model.bond_count(), 0);
    assert_eq!(sim.model.particles.force[0], Vec3::zeros(), "a broken bond carries no tension");
}

/// One step of the shear test: tangential and normal force on particle 1, and the normal
/// force Kn·δ expected from the overlap at the positions the force was computed at.
struct ShearSample {
    time: f64,
    tangential: f64,
    normal: f64,
    kn_delta: f64,
    /// Friction heat booked during the step (J).
    heat: f64,
}

/// Friction heat booked so far, both halves of every pair (J).
fn friction_heat(model: &Model) -> f64 {
    model.particles.heat.friction.iter().sum()
}

/// Speed at which the shear tests slide particle 1 along y (m/s).
const SHEAR_SPEED: f64 = 0.01;

/// Presses two bonded spheres together (overlap 1e-5 m: Fn = Kn·δ = 10 N), then shears
/// them: particle 1 slides along y at 1 cm/s (Ks·Δu = 0.01 N per step, 1e-3 of the peak).
fn shear_bonded_pair(steps: usize) -> (Simulation, Vec<ShearSample>) {
    shear_pair(bond_material(), true, steps)
}

fn shear_pair(mat: Material, bonded: bool, steps: usize) -> (Simulation, Vec<ShearSample>) {
    let kn = mat.kn;
    let mut sim = prescribed_pair(mat, bonded, 1e-5, Vec3::zeros(), Vec3::new(0.0, SHEAR_SPEED, 0.0));
    let mut samples = Vec::with_capacity(steps);
    for _ in 0..steps {
        let (a, b) = (sim.model.particles.pos[0], sim.model.particles.pos[1]);
        let time = sim.model.clock.time;
        let heat_before = friction_heat(&sim.model);
        run(&mut sim, 1).unwrap();
        let n = (a - b).normalize(); // from particle 1 towards particle 0
        let f = sim.model.particles.force[1];
        let normal = -f.dot(&n); // compressive push away from particle 0
        let tangential = (f - n * f.dot(&n)).norm();
        let kn_delta = kn * (2.0 * BOND_R - (a - b).norm());
        let heat = friction_heat(&sim.model) - heat_before;
        samples.push(ShearSample { time, tangential, normal, kn_delta, heat });
    }
    (sim, samples)
}

// Shear (paper 003 §2): a bonded pair pressed with Fn = Kn·δ = 10 N and sheared; the
// shear force peaks at Fs0 + μp·Fn (= 10 N) within 1%, and a Shear breakage of pair
// (0, 1) is recorded when the shear spring reaches it, t = (Fs0 + μp·Fn)/(Ks·v) within 1%.
#[test]
fn bonded_pair_sheared_slips_at_fs0_plus_mu_fn() {
    let mat = bond_material();
    let (sim, samples) = shear_bonded_pair(1500);
    let peak = samples.iter().max_by(|a, b| a.tangential.total_cmp(&b.tangential)).unwrap();
    let expected = mat.fs0 + mat.mu_p * peak.kn_delta;
    let b = *sim.model.breakages.first().expect("the bond must fail in shear");
    let t_expected = expected / (mat.ks * 0.01);
    eprintln!(
        "shear: peak {:.6} N at Fn = {:.6} N (expected Fs0 + μp·Fn = {expected:.6} N, {:+.2e}); broke at \
         t = {:.6e} s (expected {t_expected:.6e} s)",
        peak.tangential,
        peak.normal,
        peak.tangential / expected - 1.0,
        b.time
    );
    assert!(rel(peak.normal, peak.kn_delta) < 1e-9, "the pair is pressed with Kn·δ");
    assert!(rel(peak.tangential, expected) < 0.01, "peak shear {}", peak.tangential);
    assert_eq!(sim.model.breakages.len(), 1);
    assert_eq!((b.i, b.j, b.kind), (0, 1, BreakKind::Shear));
    assert!(rel(b.time, t_expected) < 0.01, "break time {}", b.time);
    assert!(peak.time < b.time, "the peak comes before the bond fails");
    assert_eq!(sim.model.bond_count(), 0);
}

// Friction after failure (paper 003 §2): once the bond has failed in shear the pair slides
// with resistance μp·Fn. Checked at every step of 500 steps of sliding after the break
// (Fn from the overlap of that step), tolerance 1%.
#[test]
fn broken_pair_slides_at_mu_fn() {
    let mu = bond_material().mu_p;
    let (sim, samples) = shear_bonded_pair(1500);
    let b = sim.model.breakages[0];
    let sliding: Vec<&ShearSample> = samples.iter().filter(|s| s.time > b.time).collect();
    assert!(sliding.len() >= 400, "the pair must slide for a while after the break");
    let worst = sliding.iter().map(|s| rel(s.tangential, mu * s.kn_delta)).fold(0.0, f64::max);
    let last = sliding.last().unwrap();
    eprintln!(
        "sliding: {} steps after the break, last Ft = {:.6} N vs μp·Fn = {:.6} N; worst deviation {worst:.2e}",
        sliding.len(),
        last.tangential,
        mu * last.kn_delta
    );
    assert!(worst < 0.01, "sliding resistance deviates from μp·Fn by {worst}");
    // The heat booked is the work of that resistance over the slip, μp·Fn·v·dt per step.
    let heat: f64 = sliding.iter().map(|s| s.heat).sum();
    let work: f64 = sliding.iter().map(|s| mu * s.kn_delta * SHEAR_SPEED * BOND_DT).sum();
    eprintln!("sliding: friction heat {heat:.6e} J vs μp·Fn·slip {work:.6e} J ({:+.2e})", heat / work - 1.0);
    assert!(rel(heat, work) < 0.01, "friction heat {heat} vs work {work}");
}

// Coulomb friction with μp = 0 (paper 003 §2): an unbonded pair pressed with Kn·δ = 10 N and
// slid for 1000 steps carries no shear force (to round-off, 1e-12 of Fn, of splitting the
// force into normal and tangential parts) and books no friction heat (exactly 0: no force, no
// work).
#[test]
fn frictionless_sliding_carries_no_shear_and_books_no_heat() {
    let mut mat = bond_material();
    mat.mu_p = 0.0;
    let (sim, samples) = shear_pair(mat, false, 1000);
    let max_shear = samples.iter().map(|s| s.tangential).fold(0.0, f64::max);
    let heat = friction_heat(&sim.model);
    eprintln!("frictionless: max shear force {max_shear:e} N, friction heat {heat:e} J");
    assert!(samples.iter().all(|s| rel(s.normal, s.kn_delta) < 1e-9), "the pair stays pressed");
    assert!(max_shear < 1e-12 * 10.0, "shear force {max_shear} (round-off of the 10 N normal force only)");
    assert_eq!(heat, 0.0);
}

/// A box of `nx·ny·nz` spheres of random radii on a slightly overlapping grid, with random
/// velocities, gravity, five walls, rotation, friction and a dashpot.
fn shaken_box(nx: usize, ny: usize, nz: usize, seed: u64) -> Model {
    let r0 = 0.01;
    let mut model = Model::new();
    model.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    model.settings.rotation = true;
    let mut mat = material("sand", 2650.0, 1e5, 1e9, 0.0);
    mat.ks = 4e4;
    mat.mu_p = 0.5;
    mat.restitution = 0.5;
    let k = model.add_material(mat).unwrap();
    let mut rng = Rng::new(seed);
    // Grid pitch a little over the mean diameter, so many neighbours start pressed.
    let s = 2.05 * r0;
    let (w, l) = (nx as f64 * s, ny as f64 * s);
    for iz in 0..nz {
        for iy in 0..ny {
            for ix in 0..nx {
                let r = r0 * (0.9 + 0.2 * rng.uniform());
                let pos = Vec3::new((ix as f64 + 0.5) * s, (iy as f64 + 0.5) * s, (iz as f64 + 0.5) * s);
                let id = model.add_particle(pos, r, k).unwrap();
                let mut u = || rng.uniform() - 0.5;
                model.particles.vel[id] = Vec3::new(u(), u(), u());
            }
        }
    }
    let walls = [
        ("floor", Vec3::zeros(), Vec3::z()),
        ("left", Vec3::zeros(), Vec3::x()),
        ("right", Vec3::new(w, 0.0, 0.0), -Vec3::x()),
        ("front", Vec3::zeros(), Vec3::y()),
        ("back", Vec3::new(0.0, l, 0.0), -Vec3::y()),
    ];
    for (name, point, normal) in walls {
        model.add_wall(Wall::plane(name, point, normal, 1.0).unwrap()).unwrap();
    }
    model.set_standard_dt().unwrap();
    model
}

/// Bit patterns of a lane, so that −0.0 ≠ 0.0 and NaN = NaN.
fn bits(v: &[Vec3]) -> Vec<[u64; 3]> {
    v.iter().map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()]).collect()
}

// Determinism (engine design, backend/cpu/blocks.rs: fixed block tree, no atomics): 672
// particles (three blocks of 256, so the work really splits) with gravity, walls, rotation,
// friction and a dashpot, 300 steps on a 1-thread and a 2-thread pool. Positions,
// velocities and angular velocities must be bitwise equal (tolerance: none).
#[test]
fn run_is_deterministic_across_thread_counts() {
    let run_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut sim = Simulation::new(shaken_box(12, 8, 7, 42));
            assert!(sim.model.len() > 2 * 256);
            let contacts_before = sim.contact_stats().contacts;
            run(&mut sim, 300).unwrap();
            let energies = sim.energies();
            let p = &sim.model.particles;
            let ang_vel = p.rotation.as_ref().map(|r| r.ang_vel.clone()).unwrap_or_default();
            (bits(&p.pos), bits(&p.vel), bits(&ang_vel), contacts_before, ang_vel, energies)
        })
    };
    let one = run_on(1);
    let two = run_on(2);
    let spin = one.4.iter().map(|w| w.norm()).fold(0.0, f64::max);
    let e = one.5;
    eprintln!(
        "determinism: {} contacts at the start, largest spin {spin:.3e} rad/s, heat: friction {:.3e} J, \
         dashpot {:.3e} J",
        one.3, e.heat_friction, e.heat_contact_damping
    );
    // The scene exercises what it claims to.
    assert!(one.3 > 400, "the scene must start with many contacts");
    assert!(spin > 0.0, "rotation must be simulated (settings.rotation = true)");
    assert!(e.heat_friction > 0.0 && e.heat_contact_damping > 0.0, "friction and dashpot must act");
    assert!(one.0 == two.0, "positions differ between 1 and 2 threads");
    assert!(one.1 == two.1, "velocities differ between 1 and 2 threads");
    assert!(one.2 == two.2, "angular velocities differ between 1 and 2 threads");
}

// The fused step (backend/cpu/fused.rs): an unobserved step gathers, meets the walls and
// integrates each particle in one pass; an observed step runs the same stages as separate
// passes. Both must give the same bits (tolerance: none) for every lane a step writes: the
// shaken box as above, and again with global and local damping, bonds (some break: heat of
// breakage) and a moving wall (wall work). A third run takes the 300 steps as one chunk of
// a simulation run, where the pair states stay in the pair records from step to step and
// reach the rows only before a neighbour rebuild and at the end (contact_forces.rs,
// `PairScratch`): the same bits again, through at least one rebuild.
#[test]
fn fused_step_matches_separate_passes_bit_for_bit() {
    use matdem_engine::backend::cpu::CpuBackend;
    use matdem_engine::WallMotion;
    let scenes = |variant: usize| {
        let mut m = shaken_box(12, 8, 7, 7);
        if variant == 1 {
            m.settings.damping = 0.2;
            m.settings.local_damping = 0.1;
            m.materials[0].xb = 2e-4;
            m.materials[0].fs0 = 1.0;
            assert!(m.connect(None, 1e-3).unwrap() > 100, "the scene must hold bonds");
            m.walls[0].motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, 0.05));
        }
        m
    };
    for variant in 0..2 {
        let mut lanes = Vec::new();
        for mode in ["fused", "observed", "one run"] {
            let mut m = scenes(variant);
            let start = m.particles.pos.clone();
            if mode == "one run" {
                m.settings.guard_every = 1000;
                let mut sim = Simulation::new(m);
                run(&mut sim, 300).unwrap();
                m = sim.model;
                assert!(m.contacts.built_at != start, "variant {variant}: the rows must be rebuilt during the run");
            } else {
                let mut cpu = CpuBackend::prepare(&m);
                for _ in 0..300 {
                    cpu.step(&mut m, mode == "observed");
                }
            }
            let p = &m.particles;
            let rot = p.rotation.as_ref().unwrap();
            let h = &p.heat;
            let heat: Vec<u64> = [&h.damping, &h.contact_damping, &h.friction, &h.breakage, &h.wall_work]
                .iter()
                .flat_map(|lane| lane.iter().map(|x| x.to_bits()))
                .collect();
            let states: Vec<_> = m.contacts.state.iter().chain(&m.wall_contacts).map(|s| format!("{s:?}")).collect();
            let walls: Vec<_> = m.walls.iter().map(|w| bits(&[w.force])).collect();
            let lane = (bits(&p.pos), bits(&p.vel), bits(&rot.ang_vel), bits(&p.force), bits(&rot.torque));
            lanes.push((lane, heat, states, walls, m.breakages.len()));
        }
        let (fused, separate, one_run) = (&lanes[0], &lanes[1], &lanes[2]);
        let touching = separate.3.iter().filter(|f| f[0] != [0; 3]).count();
        eprintln!("fused vs separate, variant {variant}: {} breakages, {touching} walls loaded", separate.4);
        assert!(touching >= 3, "walls must carry load");
        if variant == 1 {
            assert!(separate.4 > 0, "some bonds must break");
        }
        assert!(fused.0 == separate.0, "variant {variant}: particle lanes differ");
        assert!(fused.1 == separate.1, "variant {variant}: heat ledger differs");
        assert!(fused.2 == separate.2, "variant {variant}: contact states differ");
        assert!(fused.3 == separate.3, "variant {variant}: wall loads differ");
        assert_eq!(fused.4, separate.4, "variant {variant}: breakages differ");
        assert!(one_run == separate, "variant {variant}: a run of fused steps differs from separate passes");
    }
}

// The stability guard (guard.rs; timestep.rs: the explicit step is stable up to
// dt = T/(√2·π) = √2·√(m/k) for an element of mass m on its stiffest spring k = 2·kn).
// Three spheres, the smallest (id 2) has the shortest critical step; at dt = 10× that step
// the run must stop with Error::Unstable naming particle 2, the critical step (to the
// printed 4 digits) and the fix, and leave no NaN behind.
#[test]
fn unstable_time_step_stops_with_guard_message() {
    let (density, kn) = (2650.0, 1e6);
    let radii = [0.01, 0.012, 0.005];
    let mut model = Model::new();
    let k = model.add_material(material("rock", density, kn, 1e9, 0.0)).unwrap();
    for (i, r) in radii.iter().enumerate() {
        model.add_particle(Vec3::new(0.03 * i as f64, 0.0, 0.0), *r, k).unwrap();
    }
    model.particles.vel[0] = Vec3::new(1.0, 0.0, 0.0);
    // Expected: the element with the shortest √2·√(m/(2·kn)).
    let crit = |r: f64| std::f64::consts::SQRT_2 * (sphere_mass(density, r) / (2.0 * kn)).sqrt();
    let (worst, expected) =
        radii.iter().enumerate().map(|(i, r)| (i, crit(*r))).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert_eq!(worst, 2);
    let (i, critical) = model.critical_dt().unwrap();
    assert_eq!(i, worst);
    assert!(rel(critical, expected) < 1e-12, "critical step {critical} vs {expected}");

    model.set_dt(10.0 * critical).unwrap();
    let mut sim = Simulation::new(model);
    let err = run(&mut sim, 100).expect_err("a step 10× the critical one must be refused");
    let msg = err.to_string();
    eprintln!("guard: {msg}");
    match &err {
        Error::Unstable(inst) => {
            assert_eq!(inst.particle, worst);
            assert!(rel(inst.critical_dt, expected) < 1e-12);
        }
        other => panic!("expected Error::Unstable, got {other:?}"),
    }
    assert!(msg.contains(&format!("particle {worst}")), "names the particle: {msg}");
    assert!(msg.contains("critical time step") && msg.contains(&format!("{expected:.3e}")), "{msg}");
    assert!(msg.contains("Fix:") && msg.contains("set_standard_dt"), "names the fix: {msg}");
    let p = &sim.model.particles;
    let finite = |v: &[Vec3]| v.iter().all(|x| x.iter().all(|c| c.is_finite()));
    assert!(finite(&p.pos) && finite(&p.vel) && finite(&p.force), "no NaN after the guard stopped the run");
}

// Energy of a contact (physics.md §2: elastic energy ½·k·δ² of the linear spring) is
// available before any step has run: two spheres overlapping by 1e-5 m with k = 1e6 N/m
// store 5e-5 J. Tolerance 1e-9 relative.
#[test]
fn energies_before_the_first_step_include_initial_overlaps() {
    let (kn, overlap) = (1e6, 1e-5);
    let model = two_spheres(material("rock", 2650.0, kn, 1e9, 0.0), 0.01, -overlap, 0.0, NormalKind::Linear);
    let mut sim = Simulation::new(model);
    let e = sim.energies();
    assert!(rel(e.normal_elastic, 0.5 * kn * overlap * overlap) < 1e-9, "{e:?}");
    assert_eq!(e.kinetic, 0.0);
}

// Rotation (contact_law.rs: torque (n·r) × shear): a sphere sliding on a floor with friction
// spins up; once settings.rotation is switched off its spin must stay exactly as it was
// (no torque is computed any more, so none may be applied).
#[test]
fn switching_rotation_off_freezes_spin() {
    let r = 0.01;
    let mut mat = material("rock", 2650.0, 1e5, 1e9, 0.0);
    mat.ks = 4e4;
    mat.mu_p = 0.5;
    // Resting on the floor at the static overlap W/k (physics.md §2), k = 2·kn for a wall.
    let static_overlap = sphere_mass(mat.density, r) * 9.81 / (2.0 * mat.kn);
    let mut model = sphere_on_plane(mat, r, -static_overlap, 0.0, NormalKind::Linear);
    model.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    model.settings.rotation = true;
    model.particles.vel[0] = Vec3::new(0.5, 0.0, 0.0);
    model.set_standard_dt().unwrap();
    let mut sim = Simulation::new(model);
    run(&mut sim, 50).unwrap();
    let spin = |sim: &Simulation| sim.model.particles.rotation.as_ref().expect("rotation lanes").ang_vel[0];
    let before = spin(&sim);
    let torque = sim.model.particles.rotation.as_ref().unwrap().torque[0];
    assert!(torque.norm() > 0.0 && sim.model.walls[0].contacts == 1, "still sliding on the floor");
    assert!(before.y > 0.0, "sliding along +x on a floor below spins the sphere about +y: {before:?}");
    sim.model.settings.rotation = false;
    run(&mut sim, 50).unwrap();
    assert_eq!(spin(&sim), before);
}

// A model with no particles (a script that deleted them all) steps as a no-op on the CPU,
// stepped by the backend (the fused pass, its pair records synced into empty rows) and run
// by a simulation: no panic, nothing appears.
#[test]
fn a_model_without_particles_runs_and_stays_empty() {
    let mut model = Model::new();
    model.add_material(material("rock", 2650.0, 1e6, 1e6, 0.0)).unwrap();
    model.set_dt(1e-6).unwrap();
    let mut cpu = matdem_engine::backend::cpu::CpuBackend::prepare(&model);
    for _ in 0..10 {
        cpu.step(&mut model, false);
    }
    assert_eq!((model.len(), model.clock.step), (0, 10));
    let mut sim = Simulation::new(model);
    run(&mut sim, 10).unwrap();
    assert_eq!(sim.model.len(), 0);
}
