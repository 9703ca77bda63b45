//! The scaling law of paper 001 §2 (Table 1): a packing enlarged λ times keeps its contact
//! fabric, and with Kn, Ks ∝ d it keeps its small-strain E and ν; a random repacking of the
//! larger grains with the unscaled stiffness does not. Plus the exact statics: a scaled
//! copy has the same contact pairs and carries every force × λ².
//! Heavy: run in release mode.

use matdem_engine::backend::RunControl;
use matdem_engine::builder::fcc_111_block;
use matdem_engine::scaling::scaled_model;
use matdem_engine::simulation::{Balance, Simulation};
use matdem_engine::state::particles::dof;
use matdem_engine::training::{PackedSample, SampleSpec};
use matdem_engine::{Material, Model, NormalKind, Vec3, Wall, WallMotion, WallShape};

/// Paper 001 Table 1 #1: 10 mm grains, Kn 8e7 N/m, Ks = Kn/100, μ 0.8, linear contacts.
fn table1(name: &str, d: f64, kn: f64) -> Material {
    Material::from_micro(name, 2650.0, kn, kn / 100.0, 0.0, 0.0, 0.8, 0.5 * d).unwrap()
}

/// Confining stress of the paper's triaxial tests (Pa).
const CONFINING: f64 = 5e6;
/// Axial strain of the small-strain load step.
const STRAIN: f64 = 1e-4;

/// A packing in a box of six smooth walls, one material, at rest.
fn boxed(sample: &PackedSample, material: &Material) -> Model {
    let mut m = Model::new();
    let k = m.add_material(material.clone()).unwrap();
    for (x, r) in sample.pos.iter().zip(&sample.radius) {
        m.add_particle(*x, *r, k).unwrap();
    }
    let (mut lo, mut hi) = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
    for (x, r) in sample.pos.iter().zip(&sample.radius) {
        lo = lo.inf(&(x - Vec3::repeat(*r)));
        hi = hi.sup(&(x + Vec3::repeat(*r)));
    }
    let s = hi - lo;
    for (name, point, normal, area) in [
        ("bottom", lo, Vec3::z(), s.x * s.y),
        ("top", hi, -Vec3::z(), s.x * s.y),
        ("left", lo, Vec3::x(), s.y * s.z),
        ("right", hi, -Vec3::x(), s.y * s.z),
        ("front", lo, Vec3::y(), s.x * s.z),
        ("back", hi, -Vec3::y(), s.x * s.z),
    ] {
        let mut w = Wall::plane(name, point, normal, area).unwrap();
        w.friction = Some(0.0);
        m.add_wall(w).unwrap();
    }
    m.settings.local_damping = 0.7;
    m.set_standard_dt().unwrap();
    m
}

fn plane(m: &Model, name: &str) -> Vec3 {
    match &m.walls[m.wall_index(name).unwrap()].shape {
        WallShape::Plane { point, .. } => *point,
        _ => unreachable!("the box has planes only"),
    }
}

/// Width, length, height of the box.
fn size(m: &Model) -> Vec3 {
    Vec3::new(
        plane(m, "right").x - plane(m, "left").x,
        plane(m, "back").y - plane(m, "front").y,
        plane(m, "top").z - plane(m, "bottom").z,
    )
}

/// Side walls measure stress over the box's current faces.
fn update_areas(m: &mut Model) {
    let s = size(m);
    for (name, a) in [
        ("bottom", s.x * s.y),
        ("top", s.x * s.y),
        ("left", s.y * s.z),
        ("right", s.y * s.z),
        ("front", s.x * s.z),
        ("back", s.x * s.z),
    ] {
        let k = m.wall_index(name).unwrap();
        m.walls[k].area = a;
    }
}

fn balance(sim: &mut Simulation, ratio: f64, max_steps: u64) {
    let ctl = RunControl::default();
    let mut steps = 0;
    while steps < max_steps {
        steps += sim.balance(Balance::Tolerance { ratio, max_steps: 1000 }, &ctl, &mut |_| {}).unwrap().steps;
        update_areas(&mut sim.model);
        let on_target = sim
            .model
            .walls
            .iter()
            .filter(|w| matches!(w.motion, WallMotion::Servo { .. }))
            .all(|w| (w.stress() - CONFINING).abs() < 0.005 * CONFINING);
        if on_target && sim.contact_stats().unbalanced_ratio < ratio {
            break;
        }
    }
}

/// Small-strain triaxial: all six walls servo-held at 5 MPa until balanced, then the platens
/// close by STRAIN while the sides stay at 5 MPa. Returns (E, ν) from the platens' stress
/// increment and the walls' displacements. Every speed is a length over the time step, so
/// the protocol is itself similar under scaling (lengths and steps both × λ).
fn small_strain_triaxial(m: Model) -> (f64, f64) {
    let dt = m.clock.dt;
    let r_mean = m.mean_radius();
    let mut sim = Simulation::new(m);
    for w in &mut sim.model.walls {
        w.motion = WallMotion::Servo { stress: CONFINING, max_speed: 2e-3 * r_mean / dt };
    }
    balance(&mut sim, 1e-3, 200_000);
    let m = &mut sim.model;
    let (s0, d0) = (0.5 * (m.walls[0].stress() + m.walls[1].stress()), size(m));
    let steps = 1000u64;
    let v = 0.5 * STRAIN * d0.z / (steps as f64 * dt);
    m.walls[0].motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, v));
    m.walls[1].motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -v));
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
    for k in 0..2 {
        sim.model.walls[k].motion = WallMotion::Fixed;
    }
    balance(&mut sim, 1e-3, 200_000);
    let m = &sim.model;
    let (s1, d1) = (0.5 * (m.walls[0].stress() + m.walls[1].stress()), size(m));
    let axial = (d0.z - d1.z) / d0.z;
    let lateral = 0.5 * ((d1.x - d0.x) / d0.x + (d1.y - d0.y) / d0.y);
    ((s1 - s0) / axial, lateral / axial)
}

fn pack(d: f64, material: &Material, seed: u64) -> PackedSample {
    let spec =
        SampleSpec { elements: 400, radius: 0.5 * d, distri_rate: 0.2, aspect: 1.5, seed, ..SampleSpec::default() };
    PackedSample::pack(&spec, material, &RunControl::default()).unwrap()
}

#[test]
fn scaled_fabric_keeps_small_strain_elasticity_paper_001_table_1() {
    let t = std::time::Instant::now();
    let m1 = table1("case1", 0.01, 8e7);
    let fabric = boxed(&pack(0.01, &m1, 1), &m1);
    let mut rows = Vec::new();
    let (e1, nu1) = small_strain_triaxial(fabric.clone());
    rows.push(("#1", "10 mm, random packing", 8e7, e1, nu1));
    for (case, lambda) in [("#6", 3.0), ("#7", 6.0)] {
        let copy = scaled_model(&fabric, lambda, Vec3::zeros(), true).unwrap();
        let kn = copy.materials[0].kn;
        let (e, nu) = small_strain_triaxial(copy);
        rows.push((case, if lambda == 3.0 { "30 mm, #1 × 3" } else { "60 mm, #1 × 6" }, kn, e, nu));
    }
    // #2: a random repacking of 30 mm grains with #1's stiffness; #4: the same packing with
    // the scaled stiffness (same grains and porosity, but not #1's fabric).
    let m2 = table1("case2", 0.03, 8e7);
    let repacked = pack(0.03, &m2, 2);
    let (e2, nu2) = small_strain_triaxial(boxed(&repacked, &m2));
    rows.push(("#2", "30 mm, random repacking", 8e7, e2, nu2));
    let m4 = table1("case4", 0.03, 2.4e8);
    let (e4, nu4) = small_strain_triaxial(boxed(&repacked, &m4));
    rows.push(("#4", "30 mm, #2's packing", 2.4e8, e4, nu4));
    // #1's fabric enlarged, stiffness kept: the scaled geometry alone.
    let (e_geo, nu_geo) = small_strain_triaxial(scaled_model(&fabric, 3.0, Vec3::zeros(), false).unwrap());
    rows.push(("—", "30 mm, #1 × 3, Kn kept", 8e7, e_geo, nu_geo));
    eprintln!("paper 001 Table 1 at {:.0} MPa, axial strain {STRAIN:e}, {} grains:", CONFINING / 1e6, fabric.len());
    eprintln!("  case  sample                       Kn (N/m)   E (MPa)    ν        E/E#1");
    for (case, what, kn, e, nu) in &rows {
        eprintln!("  {case:4}  {what:27}  {kn:.2e}  {:9.2}  {nu:.4}  {:.4}", e / 1e6, e / e1);
    }
    eprintln!("({:.1} s)", t.elapsed().as_secs_f64());
    for (case, _, _, e, nu) in &rows[1..3] {
        assert!(((e - e1) / e1).abs() < 0.02, "{case}: E {e} against #1's {e1}");
        assert!(((nu - nu1) / nu1).abs() < 0.02, "{case}: ν {nu} against #1's {nu1}");
    }
    // Guaranteed by the law: with Kn kept, contact forces grow λ times less than areas, so
    // the 30 mm samples are softer, about 3× (exactly only at equal fabric and overlaps).
    assert!(e2 < 0.5 * e1, "#2 (random, Kn kept) should be far softer: E {e2} vs {e1}");
    assert!(e_geo < 0.5 * e1, "#1 × 3 with Kn kept should be far softer: E {e_geo} vs {e1}");
}

/// A bonded FCC lattice under a prescribed homogeneous strain, every particle held: the
/// scaled copy has the same contact pairs, and every force is the original's × λ².
#[test]
fn scaled_copy_has_the_same_contacts_and_forces_times_lambda_squared() {
    // Linear springs (Kn, Ks × λ) and Hertz (E, ν unchanged: (4/3)·E*·√(λR)·(λδ)^(3/2) = λ²·F).
    for normal in [NormalKind::Linear, NormalKind::Hertz] {
        same_contacts_and_forces_times_lambda_squared(normal);
    }
}

fn same_contacts_and_forces_times_lambda_squared(normal: NormalKind) {
    let d = 2e-3;
    let mut m = Model::new();
    let mat = Material::from_micro("rock", 2650.0, 1e7, 4e6, 1e-5, 5.0, 0.5, 0.5 * d).unwrap();
    let k = m.add_material(mat).unwrap();
    for x in fcc_111_block(4, 4, 5, d) {
        m.add_particle(x, 0.5 * d * (1.0 + 1e-9), k).unwrap();
    }
    m.connect(None, 1e-9).unwrap();
    m.settings.normal = normal;
    // Prescribed strain: 1e-3 shortening along z, 3e-4 extension along x, a 2e-4 shear.
    for x in &mut m.particles.pos {
        *x = Vec3::new(x.x * (1.0 + 3e-4) + 2e-4 * x.z, x.y, x.z * (1.0 - 1e-3));
    }
    let all: Vec<u32> = (0..m.len() as u32).collect();
    m.fix(&all, dof::ALL, true).unwrap();
    m.set_standard_dt().unwrap();
    let lambda = 2.5;
    let copy = scaled_model(&m, lambda, Vec3::new(0.1, -0.2, 0.3), true).unwrap();
    let ctl = RunControl::default();
    let mut a = Simulation::new(m);
    let mut b = Simulation::new(copy);
    a.run(1, &ctl, &mut |_| {}).unwrap();
    b.run(1, &ctl, &mut |_| {}).unwrap();
    let pairs = |m: &Model| -> Vec<(usize, u32, bool)> {
        let c = &m.contacts;
        (0..m.len())
            .flat_map(|i| c.row(i).map(move |e| (i, e)))
            .filter(|&(i, e)| {
                let j = c.other[e] as usize;
                let gap =
                    (m.particles.pos[j] - m.particles.pos[i]).norm() - m.particles.radius[i] - m.particles.radius[j];
                c.state[e].bonded || gap < 0.0
            })
            .map(|(i, e)| (i, c.other[e], c.state[e].bonded))
            .collect()
    };
    let (pa, pb) = (pairs(&a.model), pairs(&b.model));
    assert!(pa.len() > 3 * a.model.len(), "the lattice should be bonded: {} pairs", pa.len());
    assert_eq!(pa, pb, "the scaled copy must keep every contact pair");
    let f_max = a.model.particles.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
    assert!(f_max > 0.0);
    for (i, (fa, fb)) in a.model.particles.force.iter().zip(&b.model.particles.force).enumerate() {
        let err = (fb - fa * lambda * lambda).norm();
        assert!(err <= 1e-9 * f_max * lambda * lambda, "{normal:?}, particle {i}: {fb:?} vs λ²·{fa:?}");
    }
    let (ea, eb) = (a.energies().normal_elastic, b.energies().normal_elastic);
    assert!(((eb / ea) - lambda.powi(3)).abs() < 1e-9 * lambda.powi(3), "{normal:?}: elastic energy × λ³: {ea} → {eb}");
}
