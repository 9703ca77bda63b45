//! The CPT cone and rod (`WallShape::Cone`, docs/cpt.md): the distance from a point to the body
//! of revolution (face, apex, rim, rod, cap; inside and outside) against closed forms and a
//! brute-force search over the surface; the force on a single grain pressed against the face
//! and the rod against the closed-form wall contact law (linear: 2Kn·δ along the normal, Hertz:
//! 4/3·E*·√r·δ^1.5) and against the same grain on a plane tangent there, to 1e-9 relative;
//! the tip and sleeve forces (qc, fs) the wall records; and the GPU's (WGSL, f32) cone against
//! the CPU's (skipped without an adapter unless MATDEM_REQUIRE_GPU=1).

use crate::common::{material, rel, run};
use matdem_engine::state::particles::dof;
use matdem_engine::walls::{cone_profile_distance, WallPart};
use matdem_engine::{Model, NormalKind, Simulation, Vec3, Wall, WallMotion, WallShape};
use std::f64::consts::PI;

const R: f64 = 0.02;
const ROD: f64 = 0.05;
const ALPHA: f64 = PI / 6.0; // the standard 60° cone

fn cone_at(apex: Vec3, axis: Vec3) -> Wall {
    Wall::cone("cone", apex, axis, ALPHA, R, ROD).unwrap()
}

/// The cone's length along its axis, R / tan 30°.
fn h() -> f64 {
    R / ALPHA.tan()
}

/// Unit normal of the face at azimuth `e` (unit, across the axis) of a cone along `axis`.
fn face_normal(axis: Vec3, e: Vec3) -> Vec3 {
    -axis * ALPHA.sin() + e * ALPHA.cos()
}

fn close(a: Vec3, b: Vec3, tol: f64) -> bool {
    (a - b).norm() <= tol * b.norm().max(1.0)
}

// Closed forms on a cone with its apex at (0.1, −0.2, 0.3) and a tilted axis: below the apex
// on the axis, the apex region off the axis, the face (at two azimuths), the rim, the rod, the
// cap and its edge, and inside (nearest the face, the rod, the cap).
#[test]
fn distance_to_the_cone_face_apex_rim_rod_and_cap() {
    let apex = Vec3::new(0.1, -0.2, 0.3);
    let axis = Vec3::new(1.0, 2.0, 2.0) / 3.0;
    let wall = cone_at(apex, axis);
    let e1 = axis.cross(&Vec3::z()).normalize();
    let e2 = axis.cross(&e1);
    let (h, end) = (h(), h() + ROD);
    let check = |x: Vec3, n: Vec3, gap: f64, part: WallPart, what: &str| {
        let (n_got, gap_got, part_got) = wall.normal_distance_part(&x);
        assert!((gap_got - gap).abs() < 1e-14, "{what}: gap {gap_got} vs {gap}");
        assert!(close(n_got, n, 1e-12), "{what}: normal {n_got:?} vs {n:?}");
        assert_eq!(part_got, part, "{what}");
    };
    // On the axis below the apex (the radial direction is undefined there).
    check(apex - axis * 0.01, -axis, 0.01, WallPart::Tip, "axis below the apex");
    // The apex region off the axis: the apex is the nearest point.
    let x = apex - axis * 0.01 + e1 * 0.002;
    check(x, (x - apex).normalize(), (x - apex).norm(), WallPart::Tip, "apex region");
    // The face, at two azimuths: a foot on the face plus a gap along its normal.
    for (e, t) in [(e1, 0.3), (e2, 0.8)] {
        let foot = apex + axis * (t * h) + e * (t * R);
        let n = face_normal(axis, e);
        check(foot + n * 1e-3, n, 1e-3, WallPart::Tip, "face");
    }
    // The rim, where the face meets the rod: nearest for directions between their normals
    // (a tie, counted with the tip).
    let rim = apex + axis * h + e1 * R;
    let n = (face_normal(axis, e1) + e1).normalize();
    check(rim + n * 2e-3, n, 2e-3, WallPart::Tip, "rim");
    // The rod, and its cap and the cap's edge.
    check(apex + axis * (h + 0.02) + e2 * (R + 4e-3), e2, 4e-3, WallPart::Sleeve, "rod");
    check(apex + axis * (end + 5e-3) + e1 * 0.01, axis, 5e-3, WallPart::Cap, "cap");
    // The cap's edge: a tie of the rod and the cap, counted with the rod (ties go to the
    // earlier part: face, rod, cap).
    let n = (axis + e2).normalize();
    check(apex + axis * end + e2 * R + n * 3e-3, n, 3e-3, WallPart::Sleeve, "cap edge");
    // Inside: the nearest face, rod or cap line, with the gap negative.
    let s = 0.5 * h;
    check(
        apex + axis * s + e1 * 1e-3,
        face_normal(axis, e1),
        -(s * ALPHA.sin() - 1e-3 * ALPHA.cos()),
        WallPart::Tip,
        "inside near the face",
    );
    check(apex + axis * (h + 0.02) + e1 * (R - 1e-3), e1, -1e-3, WallPart::Sleeve, "inside near the rod");
    check(apex + axis * (end - 1e-3) + e2 * 1e-3, axis, -1e-3, WallPart::Cap, "inside near the cap");
}

/// Distance from (s, rho) to the profile's three segments, by sampling each at `k` points.
fn sampled_distance(s: f64, rho: f64, h: f64, end: f64, k: usize) -> f64 {
    let segments = [((0.0, 0.0), (h, R)), ((h, R), (end, R)), ((end, R), (end, 0.0))];
    let mut best = f64::INFINITY;
    for ((s0, r0), (s1, r1)) in segments {
        for j in 0..=k {
            let t = j as f64 / k as f64;
            best = best.min((s - (s0 + t * (s1 - s0))).hypot(rho - (r0 + t * (r1 - r0))));
        }
    }
    best
}

// Random points around the body: outside, the nearest point x − gap·n lies on the surface and
// no surface point (sampled every 10 µm) is nearer than the gap; inside, −gap is the distance
// to the surface (the same sampling), within the sampling's step.
#[test]
fn the_distance_is_the_nearest_surface_point_everywhere() {
    let (h, end) = (h(), h() + ROD);
    let mut seed = 12345u64;
    let mut rand = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let k = ((end + R) / 1e-5) as usize;
    let step = (end + R) / k as f64;
    for _ in 0..400 {
        let (s, rho) = (-0.02 + (end + 0.04) * rand(), 0.05 * rand());
        let (n, gap, _) = cone_profile_distance(s, rho, R, h, end);
        let brute = sampled_distance(s, rho, h, end, k);
        assert!((gap.abs() - brute).abs() <= step, "({s}, {rho}): gap {gap}, sampled {brute}");
        // The foot lies on the surface.
        let (fs, fr) = (s - gap * n[0], rho - gap * n[1]);
        let (_, on, _) = cone_profile_distance(fs, fr, R, h, end);
        assert!(on.abs() < 1e-15, "({s}, {rho}): foot ({fs}, {fr}) is {on} off the surface");
        assert!((n[0].hypot(n[1]) - 1.0).abs() < 1e-15);
    }
}

const KN: f64 = 1e5;
const GRAIN: f64 = 2e-3;

/// One grain of radius GRAIN at `x` against `wall`, held in place (all its degrees of freedom
/// fixed), no gravity; linear contacts of Kn = 1e5 N/m (a rigid wall's spring is 2Kn), Ks = Kn,
/// μ = 0.5 against walls, no dashpot.
fn grain_against(wall: Wall, x: Vec3, normal: NormalKind) -> Model {
    let mut m = Model::new();
    m.settings.normal = normal;
    let mut mat = material("sand", 2650.0, KN, 5e7, 0.25);
    mat.ks = KN;
    mat.mu_p = 0.5;
    let k = m.add_material(mat).unwrap();
    m.add_wall(wall).unwrap();
    let a = m.add_particle(x, GRAIN, k).unwrap();
    m.fix(&[a as u32], dof::ALL, true).unwrap();
    m.set_dt(1e-6).unwrap();
    m
}

// A grain pressed 0.1 mm into the face (then into the rod) of a fixed cone: the force on it is
// 2Kn·δ along the face's (rod's) normal to 1e-9, the cone's tip force is its axial reaction
// 2Kn·δ·sin 30° (the rod's sleeve force zero: a normal push on the rod has no axial part), and
// qc = tip force / πR². Hertz on the face: 4/3·E*·√r·δ^1.5, E* = E/(1 − ν²).
#[test]
fn grain_pressed_on_the_face_and_the_rod_feels_the_wall_law() {
    let axis = Vec3::z();
    let e = Vec3::new(0.6, 0.8, 0.0);
    let delta = 1e-4;
    let n_face = face_normal(axis, e);
    let foot = axis * (0.5 * h()) + e * (0.5 * R);
    let mut sim = Simulation::new(grain_against(
        cone_at(Vec3::zeros(), axis),
        foot + n_face * (GRAIN - delta),
        NormalKind::Linear,
    ));
    run(&mut sim, 1).unwrap();
    let want = n_face * (2.0 * KN * delta);
    let f = sim.model.particles.force[0];
    assert!(close(f, want, 1e-9) && rel(f.norm(), want.norm()) < 1e-9, "face: {f:?} vs {want:?}");
    let w = &sim.model.walls[0];
    let tip = 2.0 * KN * delta * ALPHA.sin();
    assert!(rel(w.tip_force, tip) < 1e-9, "tip force {} vs {tip}", w.tip_force);
    assert!(rel(w.qc(), tip / (PI * R * R)) < 1e-9);
    assert_eq!(w.sleeve_force, 0.0);

    let x = axis * (h() + 0.02) + e * (R + GRAIN - delta);
    let mut sim = Simulation::new(grain_against(cone_at(Vec3::zeros(), axis), x, NormalKind::Linear));
    run(&mut sim, 1).unwrap();
    let f = sim.model.particles.force[0];
    assert!(close(f, e * (2.0 * KN * delta), 1e-9), "rod: {f:?}");
    let w = &sim.model.walls[0];
    assert_eq!((w.tip_force, w.contacts), (0.0, 1));
    assert!(w.sleeve_force.abs() < 1e-9 * f.norm());

    let mut sim = Simulation::new(grain_against(
        cone_at(Vec3::zeros(), axis),
        foot + n_face * (GRAIN - delta),
        NormalKind::Hertz,
    ));
    run(&mut sim, 1).unwrap();
    let e_star = 5e7 / (1.0 - 0.25 * 0.25);
    let want = 4.0 / 3.0 * e_star * GRAIN.sqrt() * delta.powf(1.5);
    let f = sim.model.particles.force[0];
    assert!(rel(f.norm(), want) < 1e-9 && close(f / f.norm(), n_face, 1e-12), "hertz face: {} vs {want}", f.norm());
}

// The cone pushed along −axis at 0.2 m/s past a grain held against its face (its rod): step for
// step the force on the grain equals that of the same grain against a plane through the contact
// point with the face's (rod's) normal, moving at the same velocity (normal spring, shear spring
// and Coulomb cap together), to 1e-9; once sliding, the rod's sleeve force is μ·Fn.
#[test]
fn moving_cone_drags_a_grain_like_a_moving_tangent_plane() {
    let axis = Vec3::new(0.0, 0.6, 0.8);
    let e = axis.cross(&Vec3::x()).normalize();
    let v = -axis * 0.2;
    let delta = 5e-5;
    let cases = [
        ("face", axis * (0.6 * h()) + e * (0.6 * R), face_normal(axis, e), WallPart::Tip),
        ("rod", axis * (h() + 0.03) + e * R, e, WallPart::Sleeve),
    ];
    for (what, foot, n, part) in cases {
        let x = foot + n * (GRAIN - delta);
        let mut cone = cone_at(Vec3::zeros(), axis);
        cone.motion = WallMotion::Velocity(v);
        let mut plane = Wall::plane("cone", foot, n, 1.0).unwrap();
        plane.motion = WallMotion::Velocity(v);
        let mut a = Simulation::new(grain_against(cone, x, NormalKind::Linear));
        let mut b = Simulation::new(grain_against(plane, x, NormalKind::Linear));
        for step in 0..400 {
            run(&mut a, 1).unwrap();
            run(&mut b, 1).unwrap();
            let (fa, fb) = (a.model.particles.force[0], b.model.particles.force[0]);
            assert!(close(fa, fb, 1e-9) && rel(fa.norm(), fb.norm()) < 1e-9, "{what}, step {step}: {fa:?} vs {fb:?}");
            // The wall's axial load by part: the reaction's component along the axis.
            let w = &a.model.walls[0];
            let axial = -fa.dot(&axis);
            let (tip, sleeve) = if part == WallPart::Tip { (axial, 0.0) } else { (0.0, axial) };
            assert!(
                (w.tip_force - tip).abs() <= 1e-12 * fa.norm() && (w.sleeve_force - sleeve).abs() <= 1e-12 * fa.norm()
            );
        }
        let fa = a.model.particles.force[0];
        let fn_ = fa.dot(&n);
        let ft = fa - n * fn_;
        assert!(
            rel(ft.norm(), 0.5 * fn_) < 1e-9,
            "{what}: sliding after 400 steps: |Ft| {} vs μFn {}",
            ft.norm(),
            0.5 * fn_
        );
        if part == WallPart::Sleeve {
            // The rod moves down past the grain: friction holds it back, along +axis.
            let w = &a.model.walls[0];
            assert!(rel(w.sleeve_force, 0.5 * 2.0 * KN * delta) < 1e-9, "fs force {}", w.sleeve_force);
            assert!(rel(w.fs(), w.sleeve_force / (2.0 * PI * R * ROD)) < 1e-12);
        }
    }
}

// A cone saved and loaded keeps its shape and motion (its per-step loads are recomputed).
#[test]
fn cone_round_trips_through_a_checkpoint() {
    let mut cone = cone_at(Vec3::new(0.0, 0.0, 0.1), Vec3::z());
    cone.motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -0.02));
    let m = grain_against(cone, Vec3::new(0.0, 0.0, 0.05), NormalKind::Linear);
    let bytes = matdem_engine::checkpoint::encode(&m, &[]);
    let back = matdem_engine::checkpoint::decode(&bytes).unwrap().model;
    assert_eq!(back.walls[0].shape, m.walls[0].shape);
    assert_eq!(back.walls[0].motion, m.walls[0].motion);
    assert!(matches!(back.walls[0].shape, WallShape::Cone { .. }));
}

/// Grains around a cone pushed down at 20 mm/s: one on the face, one off the apex, one at the
/// rim, two on the rod, held in place, and one free grain falling onto the face.
#[cfg(feature = "gpu")]
fn grains_around_a_moving_cone() -> Model {
    let axis = Vec3::z();
    let mut cone = cone_at(Vec3::new(0.01, 0.02, 0.03), axis);
    cone.motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -0.02));
    let apex = Vec3::new(0.01, 0.02, 0.03);
    let e = Vec3::new(0.6, 0.8, 0.0);
    let e2 = Vec3::new(-0.8, 0.6, 0.0);
    let face = apex + axis * (0.5 * h()) + e * (0.5 * R);
    let mut m = grain_against(cone, face + face_normal(axis, e) * (GRAIN - 4e-5), NormalKind::Linear);
    let k = 0;
    let mut add = |x: Vec3, fixed: bool| {
        let a = m.add_particle(x, GRAIN, k).unwrap();
        if fixed {
            m.fix(&[a as u32], dof::ALL, true).unwrap();
        }
    };
    add(apex - axis * (GRAIN - 3e-5) + e2 * 1e-4, true);
    add(apex + axis * h() + e2 * R + (face_normal(axis, e2) + e2).normalize() * (GRAIN - 2e-5), true);
    add(apex + axis * (h() + 0.01) + e2 * (R + GRAIN - 3e-5), true);
    add(apex + axis * (h() + 0.03) + e * (R + GRAIN - 6e-5), true);
    add(apex + axis * (0.3 * h()) + (-e) * (0.3 * R) + face_normal(axis, -e) * (GRAIN + 1e-5), false);
    // The free grain moves onto the face at 0.1 m/s (it touches after ≈ 100 steps).
    m.particles.vel[5] = -face_normal(axis, -e) * 0.1;
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m
}

// The WGSL cone against the CPU's over 300 steps: each grain's force within 1e-3 of the larger
// force (f32 geometry: δ ≈ 50 µm against coordinates of 0.05 m), the tip and sleeve forces
// within 1e-3, the apex where the CPU has it to 1e-9 m.
#[cfg(feature = "gpu")]
#[test]
fn gpu_cone_matches_cpu() {
    let Some(ctx) = crate::common::gpu("gpu_cone") else { return };
    let model = grains_around_a_moving_cone();
    let mut cpu = Simulation::new(model.clone());
    let mut gpu = Simulation::with_gpu(model, ctx);
    for chunk in 0..6 {
        run(&mut cpu, 50).unwrap();
        run(&mut gpu, 50).unwrap();
        let (a, b) = (&cpu.model, &gpu.model);
        let scale = a.particles.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
        assert!(scale > 0.0);
        for (i, (fa, fb)) in a.particles.force.iter().zip(&b.particles.force).enumerate() {
            assert!((fa - fb).norm() <= 1e-3 * scale, "chunk {chunk}, grain {i}: cpu {fa:?} gpu {fb:?}");
        }
        let (wa, wb) = (&a.walls[0], &b.walls[0]);
        eprintln!(
            "chunk {chunk}: tip cpu {:.6e} gpu {:.6e}; sleeve cpu {:.6e} gpu {:.6e}; contacts {} {}",
            wa.tip_force, wb.tip_force, wa.sleeve_force, wb.sleeve_force, wa.contacts, wb.contacts
        );
        assert_eq!(wa.contacts, wb.contacts);
        assert!((wa.tip_force - wb.tip_force).abs() <= 1e-3 * scale, "tip force");
        assert!((wa.sleeve_force - wb.sleeve_force).abs() <= 1e-3 * scale, "sleeve force");
        let (pa, pb) = match (&wa.shape, &wb.shape) {
            (WallShape::Cone { apex: pa, .. }, WallShape::Cone { apex: pb, .. }) => (*pa, *pb),
            _ => unreachable!(),
        };
        assert!((pa - pb).norm() < 1e-9, "apex {pa:?} vs {pb:?}");
        assert!(wa.tip_force > 0.0 && wa.sleeve_force > 0.0);
    }
}
