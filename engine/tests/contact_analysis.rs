//! The analysis of a settled model (`matdem_engine::analysis`): the contact list, its sums
//! and Newton's third law; the fabric of a perfect FCC lattice; Love–Weber stress against
//! the lattice's elastic answer and against a servo platen; strain from the best-fit
//! displacement gradient; and the contact list on the GPU against the CPU.
//!
//! Run with `--nocapture` to see the measured figures (docs/analysis.md quotes them). The
//! scenes with walls are the GPU parity tests' oedometer sample, so the file needs the `gpu`
//! feature (the default) to build; its CPU tests run without an adapter.
#![cfg(feature = "gpu")]

use crate::common::run;
use crate::gpu_parity::oedometer_sample;
use matdem_engine::analysis::{fabric, measure, strain, ContactList, Other, Region};
use matdem_engine::builder::{fcc_111_block, BoxSpec, Container, SizeClass};
use matdem_engine::physics::contact_law::{contact, ContactGeometry, Hertz, MindlinShear, PairState};
use matdem_engine::state::particles::dof;
use matdem_engine::{Material, Model, Simulation, Vec3, WallMotion, WallShape};
use nalgebra::Matrix3;

/// Σ of the forces the rows put on each element: +force on `i`, −force on `j`.
fn row_sums(list: &ContactList, n: usize) -> Vec<Vec3> {
    let mut sum = vec![Vec3::zeros(); n];
    for r in &list.rows {
        sum[r.i as usize] += r.force;
        if let Other::Element(j) = r.other {
            sum[j as usize] -= r.force;
        }
    }
    sum
}

/// The oedometer sample of the GPU parity tests (64 grains, Hertz–Mindlin with rotation and a
/// dashpot, in a ring on a floor), its platen servo-controlled to 20 kPa for `steps` steps.
fn loaded_oedometer(steps: u64) -> Simulation {
    let mut m = oedometer_sample();
    m.wall_mut("top_platen").unwrap().motion = WallMotion::Servo { stress: 2e4, max_speed: 0.2 };
    let mut sim = Simulation::new(m);
    run(&mut sim, steps).unwrap();
    sim
}

// Every row's force is booked on both its ends: on the oedometer stage (walls, rotation,
// dashpot) the per-element sums of the rows equal the list's force lanes to round-off. In a
// balanced box the lanes, evaluated at the positions the run left, equal the last step's force
// lane (`Particles::force`, `d.fx`, taken before that step's move; the scene has no other force
// stage) within 1e-3 of the mean contact force.
#[test]
fn contact_rows_sum_to_each_elements_contact_force_lane() {
    let mut sim = loaded_oedometer(3000);
    let list = sim.contact_list();
    let n = sim.model.len();
    let sums = row_sums(&list, n);
    let mean = |l: &ContactList| {
        let active = l.rows.iter().filter(|r| r.is_active());
        active.clone().map(|r| r.force.norm()).sum::<f64>() / active.count() as f64
    };
    let scale = mean(&list);
    let worst_sum = (0..n).map(|i| (sums[i] - list.force[i]).norm() / scale).fold(0.0, f64::max);
    let walls = list.rows.iter().filter(|r| matches!(r.other, Other::Wall(_))).count();
    let (mut boxed, _) = balanced_servo_box();
    let settled = boxed.contact_list();
    let p = &boxed.model.particles;
    let worst_step = (0..p.len()).map(|i| (settled.force[i] - p.force[i]).norm() / mean(&settled)).fold(0.0, f64::max);
    eprintln!(
        "oedometer: {} rows ({walls} with walls), mean |f| {scale:.3e} N, rows vs lanes {worst_sum:.2e}; balanced \
         box: lanes vs the last step's force {worst_step:.2e} of the mean |f|",
        list.rows.len()
    );
    assert!(walls > 0 && list.rows.len() > walls);
    assert!(worst_sum < 1e-12, "rows vs lanes {worst_sum}");
    assert!(worst_step < 1e-3, "lanes vs the last step's force {worst_step}");
}

/// ~240 grains (r 0.2–0.3 mm, linear springs, μp 0.5) deposited in a 3 mm square box under
/// 100 g with local damping, loaded by a servo platen to 100 kPa, then gravity switched off and
/// the box balanced again (unbalanced force ratio 6e-6). The floor and the sides are
/// frictionless, so that they carry no vertical load. Returns the simulation and the platen's
/// target.
fn balanced_servo_box() -> (Simulation, f64) {
    let target = 100e3;
    let mut m = Model::new();
    let sand = Material::from_micro("sand", 2650.0, 2e5, 1e5, 0.0, 0.0, 0.5, 0.25e-3).unwrap();
    m.add_material(sand).unwrap();
    let spec = BoxSpec {
        container: Container::Cuboid { width: BOX_W, length: BOX_W },
        height: BOX_W,
        classes: vec![SizeClass { r_min: 0.2e-3, r_max: 0.3e-3, mass_ratio: 1.0 }],
        target_porosity: 0.4,
        seed: 7,
        top_platen: true,
    };
    spec.build_into(&mut m).unwrap();
    m.set_standard_dt().unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -981.0);
    m.settings.local_damping = 0.7;
    let mut sim = Simulation::new(m);
    run(&mut sim, 40_000).unwrap();
    let m = &mut sim.model;
    for wall in m.walls.iter_mut().filter(|w| w.name != "top_platen") {
        wall.friction = Some(0.0);
    }
    let top = (0..m.len()).map(|i| m.particles.pos[i].z + m.particles.radius[i]).fold(0.0, f64::max);
    let dt = m.clock.dt;
    let platen = m.wall_mut("top_platen").unwrap();
    platen.shape = WallShape::Plane { point: Vec3::new(0.0, 0.0, top), normal: -Vec3::z() };
    platen.motion = WallMotion::Servo { stress: target, max_speed: 2e-3 * 0.25e-3 / dt };
    run(&mut sim, 80_000).unwrap();
    sim.model.settings.gravity = Vec3::zeros();
    run(&mut sim, 40_000).unwrap();
    (sim, target)
}

/// The servo box's width (m).
const BOX_W: f64 = 3e-3;

// Newton's third law over the table: seen from the other element (normal, relative velocity
// and shear spring mirrored) the law gives exactly the opposite force, so the list books each
// pair once; summed over every element, the pairs cancel and what is left is the walls' share.
#[test]
fn contact_table_obeys_newtons_third_law() {
    let mut sim = loaded_oedometer(3000);
    let list = sim.contact_list();
    let plan = sim.plan().clone();
    let m = &sim.model;
    let p = &m.particles;
    let mut worst = 0.0f64;
    for r in list.rows.iter().filter(|r| r.is_active()) {
        let Other::Element(j) = r.other else { continue };
        let (i, j) = (r.i as usize, j as usize);
        let k = m.contacts.find(j, i as u32).unwrap();
        let (ri, rj) = (p.radius[i], p.radius[j]);
        let w = |q: usize| p.rotation.as_ref().unwrap().ang_vel[q];
        let n = -r.normal;
        let v_rel = p.vel[j] - p.vel[i] + w(j).cross(&(n * rj)) - w(i).cross(&(n * -ri));
        let g = ContactGeometry {
            n,
            overlap: r.overlap,
            v_rel,
            r_star: ri * rj / (ri + rj),
            m_star: p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]),
        };
        let mut st: PairState = m.contacts.state[k];
        let seen_from_j =
            contact::<Hertz, MindlinShear, true>(&g, plan.pair(p.material[j], p.material[i]), &mut st, 0.0);
        worst = worst.max((seen_from_j.force + r.force).norm() / r.force.norm().max(1e-300));
    }
    let total: Vec3 = list.force.iter().sum();
    let on_walls: Vec3 = list.rows.iter().filter(|r| matches!(r.other, Other::Wall(_))).map(|r| r.force).sum();
    let scale: f64 = list.rows.iter().map(|r| r.force.norm()).sum();
    let residual = (total - on_walls).norm() / scale;
    eprintln!("worst |f_ij + f_ji| / |f| {worst:.2e}; Σ forces − walls' share {residual:.2e} of Σ|f|");
    assert!(worst < 1e-12, "third law per pair {worst}");
    assert!(residual < 1e-14, "the pairs cancel in the total: {residual}");
}

/// A perfect FCC block of diameter `d`, every touching pair bonded (so every neighbour is a
/// contact at zero overlap), its material linear with springs `kn`, `ks`.
fn fcc_block(n: usize, layers: usize, d: f64, kn: f64, ks: f64) -> Model {
    let mut m = Model::new();
    let mat = Material::from_micro("lattice", 2600.0, kn, ks, 1.0, 1e6, 0.5, d / 2.0).unwrap();
    m.add_material(mat).unwrap();
    for x in fcc_111_block(n, n, layers, d) {
        m.add_particle(x, d / 2.0, 0).unwrap();
    }
    m.connect(None, 1e-6 * d).unwrap();
    m
}

// A perfect FCC lattice: every element inside has twelve neighbours along six directions
// ±n, whose Σ n ⊗ n is 4·I, so the fabric of a region holding interior elements only is I/3
// and its coordination 12 (to round-off: 1e-12).
#[test]
fn fabric_of_a_perfect_fcc_interior_is_one_third_of_the_identity_with_coordination_twelve() {
    let d = 1e-3;
    let mut sim = Simulation::new(fcc_block(10, 10, d, 1e6, 0.0));
    let list = sim.contact_list();
    let centre = Vec3::new(5.3 * d, 4.3 * d, 3.6 * d);
    let region = Region::Sphere { center: centre, radius: 2.6 * d };
    let f = fabric(&sim.model, &list, Some(&region)).unwrap();
    let error = (f.tensor - Matrix3::identity() / 3.0).abs().max();
    eprintln!(
        "{} elements, coordination {}, |F − I/3| {error:.2e}, principal {:?}",
        f.elements, f.coordination, f.values
    );
    assert!(f.elements > 50);
    assert!(error < 1e-12, "F = {}", f.tensor);
    assert!((f.coordination - 12.0).abs() < 1e-12);
    for v in f.values {
        assert!((v - 1.0 / 3.0).abs() < 1e-12);
    }
    // The whole block is not isotropic: its faces lack neighbours.
    let whole = fabric(&sim.model, &list, None).unwrap();
    assert!(whole.coordination < 11.0, "{}", whole.coordination);
}

// Love–Weber stress of a bonded FCC lattice under a uniform strain. Every element is held and
// moved at v = ε̇·(x − x0), so the deformation is affine and each pair's relative
// displacement is Δu = ε·l: its force on i is Kn·(n·Δu)·n + Ks·(Δu − n(n·Δu)) (the linear
// law, the incremental shear spring having integrated Δu's tangential part). The elastic
// answer is σ = −(1/(2·V_e))·Σ_{12 neighbours} f ⊗ l with V_e = d³/√2 the volume per element,
// computed here from the twelve neighbour vectors of an interior element; in the lattice's
// cubic axes this is C11 = √2(Kn + Ks)/d, C12 = (Kn − Ks)/(√2·d), C44 = (Kn + Ks)/(√2·d). The
// region is a box of whole lattice periods (d × √3·d × √6·d), where counting elements by their
// centres fills its volume exactly. Tolerance 1e-3 of |σ|: the law acts on the deformed
// geometry and the springs turn with the normals, effects of the order of the strain (1e-4).
#[test]
fn love_weber_stress_of_a_strained_fcc_lattice_equals_the_elastic_answer() {
    let d = 1e-3;
    let (kn, ks) = (1e6, 4e5);
    let mut m = fcc_block(12, 14, d, kn, ks);
    // A general symmetric strain (no spin: a spin would load the shear springs of elements
    // that do not rotate), reached in `steps` steps.
    let eps = Matrix3::new(-1.0e-4, 0.3e-4, -0.2e-4, 0.3e-4, 0.5e-4, 0.4e-4, -0.2e-4, 0.4e-4, -0.6e-4);
    let (steps, dt) = (200u64, 1e-7);
    let x0 = Vec3::new(6.0 * d, 6.0 * d, 5.0 * d);
    let all: Vec<u32> = (0..m.len() as u32).collect();
    let rate = eps / (steps as f64 * dt);
    for i in 0..m.len() {
        m.particles.vel[i] = rate * (m.particles.pos[i] - x0);
    }
    m.fix(&all, dof::ALL, true).unwrap();
    m.set_dt(dt).unwrap();
    let reference = m.particles.pos.clone();
    let mut sim = Simulation::new(m);
    run(&mut sim, steps).unwrap();
    let list = sim.contact_list();
    let (row, layer) = (d * 3f64.sqrt() / 2.0, d * (2.0f64 / 3.0).sqrt());
    let lo = Vec3::new(4.37 * d, 4.1 * row + 0.013 * d, 4.2 * layer);
    let region = Region::Box { lo, hi: lo + Vec3::new(3.0 * d, 2.0 * 3f64.sqrt() * d, 6f64.sqrt() * d) };
    let measured = measure(&sim.model, &list, &region).unwrap();
    // The elastic answer from an interior element's twelve neighbours (found by distance).
    let p = &reference;
    let centre = (0..p.len()).min_by(|&a, &b| (p[a] - x0).norm().total_cmp(&(p[b] - x0).norm())).unwrap();
    let mut sum = Matrix3::zeros();
    let mut neighbours = 0;
    for q in p {
        let l = q - p[centre];
        if (l.norm() - d).abs() < 1e-9 * d {
            let n = l / l.norm();
            let du = eps * l;
            let f = n * (kn * n.dot(&du)) + (du - n * n.dot(&du)) * ks;
            sum += f * l.transpose();
            neighbours += 1;
        }
    }
    assert_eq!(neighbours, 12);
    let expected = -sum / (2.0 * d * d * d / 2f64.sqrt());
    let error = (measured.stress - expected).norm() / expected.norm();
    eprintln!(
        "{} elements in the box; σ measured {:?}\nexpected {:?}; relative error {error:.2e}",
        measured.elements, measured.stress, expected
    );
    assert_eq!(measured.elements, 3 * 4 * 3, "a box of whole periods holds 3·(2 rows)·(3 layers) elements");
    assert!(error < 1e-3, "relative error {error}");
    // The same motion measured as a strain: the prescribed one, exactly (an affine motion).
    let s = strain(&reference, &sim.model.particles.pos, &vec![true; reference.len()]).unwrap();
    let f = Matrix3::identity() + eps;
    let exact = (f.transpose() * f - Matrix3::identity()) * -0.5;
    let strain_error = (s.strain - exact).abs().max();
    eprintln!("strain error {strain_error:.2e}, residual {:.2e} m", s.residual);
    assert!(strain_error < 1e-12, "{strain_error}");
}

// In a balanced box under a servo platen, without gravity and with frictionless sides, σzz of
// the sample (walls' contacts counted, on their surfaces) and of its middle half (a slab
// across the box, z from ¼ to ¾ of the height; contacts cut by its faces counted by their
// branch's share) equal the platen's stress within 2 % (measured 1.4e-5 and 1.8e-5). A core
// cylinder in the middle is printed only: this loose sample (coordination 1.25) carries its
// load in a few columns, and the core reads about twice the platen's stress.
#[test]
fn love_weber_stress_in_a_balanced_servo_box_equals_the_platens_stress() {
    let (mut sim, target) = balanced_servo_box();
    let k = sim.model.wall_index("top_platen").unwrap();
    let platen_stress = sim.model.walls[k].stress();
    let WallShape::Plane { point, .. } = sim.model.walls[k].shape else { unreachable!() };
    let list = sim.contact_list();
    let w = BOX_W;
    let whole = Region::Box { lo: Vec3::zeros(), hi: Vec3::new(w, w, point.z) };
    let middle = Region::Box { lo: Vec3::new(0.0, 0.0, 0.25 * point.z), hi: Vec3::new(w, w, 0.75 * point.z) };
    let a = measure(&sim.model, &list, &whole).unwrap();
    let b = measure(&sim.model, &list, &middle).unwrap();
    let core = Region::Cylinder {
        center: Vec3::new(0.5 * w, 0.5 * w, 0.0),
        radius: 0.35 * w,
        z0: 0.25 * point.z,
        z1: 0.75 * point.z,
    };
    let c = measure(&sim.model, &list, &core).unwrap();
    eprintln!("core cylinder σzz {:.1} Pa ({} elements)", c.stress[(2, 2)], c.elements);
    let unbalanced = sim.contact_stats().unbalanced_ratio;
    eprintln!(
        "{} grains; platen {platen_stress:.1} Pa (target {target}); σzz whole {:.1} Pa ({} elements), middle {:.1} Pa \
         ({} elements, porosity {:.3}, coordination {:.2}); σxx middle {:.1}; unbalanced {unbalanced:.2e}",
        sim.model.len(),
        a.stress[(2, 2)],
        a.elements,
        b.stress[(2, 2)],
        b.elements,
        b.porosity,
        b.coordination,
        b.stress[(0, 0)]
    );
    assert!((platen_stress / target - 1.0).abs() < 0.01, "the platen holds its target");
    assert!((a.stress[(2, 2)] / platen_stress - 1.0).abs() < 0.02, "whole sample");
    assert!((b.stress[(2, 2)] / platen_stress - 1.0).abs() < 0.02, "middle");
}

// Strain from the best-fit displacement gradient: a rigid rotation of 30° (with a
// translation) gives zero strain and no volume change; a prescribed affine deformation F
// gives its Green–Lagrange strain −½(FᵀF − I) exactly (compression positive), with a zero
// residual; elements in one plane are refused.
#[test]
fn rigid_rotation_gives_zero_strain_and_an_affine_deformation_its_exact_strain() {
    let reference = fcc_111_block(4, 4, 4, 1e-3);
    let all = vec![true; reference.len()];
    let axis = nalgebra::Unit::new_normalize(Vec3::new(1.0, 2.0, 0.5));
    let rot = nalgebra::Rotation3::from_axis_angle(&axis, 30f64.to_radians());
    let shift = Vec3::new(0.1, -0.2, 0.05);
    let turned: Vec<Vec3> = reference.iter().map(|x| rot * x + shift).collect();
    let s = strain(&reference, &turned, &all).unwrap();
    eprintln!("rotation: |E| {:.2e}, det F − 1 {:.2e}", s.strain.abs().max(), s.volume_change);
    assert!(s.strain.abs().max() < 1e-14 && s.volume_change.abs() < 1e-14 && s.residual < 1e-15);
    let f = Matrix3::new(1.02, 0.01, -0.03, 0.0, 0.97, 0.02, 0.015, -0.01, 1.05);
    let deformed: Vec<Vec3> = reference.iter().map(|x| f * x + shift).collect();
    let s = strain(&reference, &deformed, &all).unwrap();
    let exact = (f.transpose() * f - Matrix3::identity()) * -0.5;
    let error = (s.strain - exact).abs().max();
    eprintln!("affine: strain error {error:.2e}, volumetric {:.6}, det F − 1 {:.6}", s.volumetric, s.volume_change);
    assert!(error < 1e-13);
    assert!((s.volumetric - exact.trace()).abs() < 1e-13);
    assert!((s.volume_change - (f.determinant() - 1.0)).abs() < 1e-13);
    assert!((s.deviatoric.trace()).abs() < 1e-14);
    let flat: Vec<Vec3> = reference.iter().map(|x| Vec3::new(x.x, x.y, 0.0)).collect();
    let e = strain(&flat, &flat, &all).unwrap_err().to_string();
    assert!(e.contains("lie in one plane"), "{e}");
}

/// The oedometer stage (Hertz–Mindlin, rotation, dashpot, ring, floor and servo platen at 20 kPa).
fn oedometer_stage() -> Model {
    let mut m = oedometer_sample();
    m.wall_mut("top_platen").unwrap().motion = WallMotion::Servo { stress: 2e4, max_speed: 0.2 };
    m
}

/// How the contact tables of two runs of one scene differ: the largest difference of matched
/// rows' normal and shear forces (a fraction of `a`'s mean normal force) and of their points
/// (a fraction of the grain radius). Rows are matched by (i, other body); a row only one table has must
/// be a contact of overlap below 1e-4 of the radius (one that f32 may open or close).
fn contact_tables_differ(a: &ContactList, b: &ContactList) -> (f64, f64) {
    let key = |r: &matdem_engine::analysis::ContactRow| (r.i, r.other);
    let mean_fn = a.rows.iter().map(|r| r.normal_force.abs()).sum::<f64>() / a.rows.len() as f64;
    let r0 = crate::gpu_parity::GRAIN_R;
    let (mut worst_f, mut worst_x, mut only) = (0.0f64, 0.0f64, 0);
    for ra in &a.rows {
        match b.rows.iter().find(|rb| key(rb) == key(ra)) {
            Some(rb) => {
                worst_f = worst_f
                    .max((ra.normal_force - rb.normal_force).abs() / mean_fn)
                    .max((ra.shear_force - rb.shear_force).norm() / mean_fn);
                worst_x = worst_x.max((ra.point - rb.point).norm() / r0);
                assert_eq!(ra.bond, rb.bond);
            }
            None => {
                only += 1;
                assert!(ra.overlap < 1e-4 * r0, "row {:?} only in the first table", key(ra));
            }
        }
    }
    for rb in b.rows.iter().filter(|rb| !a.rows.iter().any(|ra| key(ra) == key(rb))) {
        only += 1;
        assert!(rb.overlap < 1e-4 * r0, "row {:?} only in the second table", key(rb));
    }
    eprintln!(
        "{} rows and {} ({only} in one only); mean Fn {mean_fn:.3e} N; worst force difference {worst_f:.2e} of it, \
         worst point {worst_x:.2e} of r",
        a.rows.len(),
        b.rows.len()
    );
    (worst_f, worst_x)
}

/// What the GPU's contact table may differ by from the CPU's after 300 steps: forces (of the
/// mean normal force) and points (of the radius).
const TABLE_PARTING: (f64, f64) = (2e-3, 1e-6);

// The GPU backend's contact list equals the CPU's on the same scene after the same steps: the
// oedometer stage after 300 steps. The table is evaluated by the same host code from each
// backend's synced state, so what differs is the state the f32 steps left: within
// `TABLE_PARTING` (`contact_tables_differ`).
#[test]
fn gpu_contact_table_matches_cpu() {
    let Some(ctx) = crate::common::gpu("gpu_contact_table") else { return };
    let mut cpu = Simulation::new(oedometer_stage());
    let mut gpu = Simulation::with_gpu(oedometer_stage(), ctx);
    run(&mut cpu, 300).unwrap();
    run(&mut gpu, 300).unwrap();
    let (worst_f, worst_x) = contact_tables_differ(&cpu.contact_list(), &gpu.contact_list());
    assert!(worst_f < TABLE_PARTING.0, "forces {worst_f}");
    assert!(worst_x < TABLE_PARTING.1, "points {worst_x}");
}

// The contact table's force tolerance against rounding alone: the CPU's run beside three rounded
// twins (each position and velocity one rounding away, `rounded_twin`) differs by less than a
// third of `TABLE_PARTING`'s forces (measured: at most 6.9e-6 of the mean normal force), so the
// parity test holds for any device's rounding, not only for the one it was measured on. The
// points are not compared here: a twin starts its grains up to 1.2e-9 m away (half an f32 ulp
// of their coordinates), 6e-7 of the radius, the scale of the points' own tolerance.
#[test]
fn the_contact_tables_parity_tolerances_hold_under_f32_rounding() {
    for seed in 1..=3 {
        let mut cpu = Simulation::new(oedometer_stage());
        let mut twin = Simulation::new(crate::common::rounded_twin(oedometer_stage(), seed));
        run(&mut cpu, 300).unwrap();
        run(&mut twin, 300).unwrap();
        let (worst_f, _) = contact_tables_differ(&cpu.contact_list(), &twin.contact_list());
        assert!(worst_f < TABLE_PARTING.0 / 3.0, "twin {seed}: forces {worst_f:e}");
    }
}
