//! Plane strips (`WallShape::Strip`, the sides of the direct shear test's half-boxes,
//! docs/direct-shear.md): the distance from a point to the strip's slab (face, ends, corner
//! edges; inside and outside) against closed forms; a grain pressed on the face, on an end and
//! on a corner edge against the wall contact law (linear: 2Kn·δ along the normal) to 1e-9;
//! the same grain on the face of a strip and of a plane step for step while the wall moves
//! past it; checkpoints; refusals; and the GPU's (WGSL, f32) strips against the CPU's
//! (skipped without an adapter unless MATDEM_REQUIRE_GPU=1).

use crate::common::{material, rel, run};
use matdem_engine::state::particles::dof;
use matdem_engine::walls::strip_profile_distance;
use matdem_engine::{Model, Simulation, Vec3, Wall, WallMotion, WallShape};

const KN: f64 = 1e5;
const GRAIN: f64 = 1e-3;

/// A side of an upper half-box: the plane x = 0.01 facing +x, from z = 0.02 up to z = 0.05.
fn side() -> Wall {
    Wall::strip("side", Vec3::new(0.01, 0.0, 0.0), Vec3::x(), Vec3::z(), 0.02, 0.05, 0.0).unwrap()
}

fn close(a: Vec3, b: Vec3, tol: f64) -> bool {
    (a - b).norm() <= tol * b.norm().max(1.0)
}

// Closed forms: the face, beyond each end (on either side of the plane), off each corner, and
// inside (nearest the face, nearest an end); the profile function alone and the wall.
#[test]
fn distance_to_the_strip_face_ends_corners_and_inside() {
    let w = side();
    let check = |x: Vec3, n: Vec3, gap: f64, what: &str| {
        let (n_got, gap_got) = w.normal_and_distance(&x);
        assert!((gap_got - gap).abs() < 1e-15, "{what}: gap {gap_got} vs {gap}");
        assert!(close(n_got, n, 1e-12), "{what}: normal {n_got:?} vs {n:?}");
    };
    check(Vec3::new(0.013, 0.4, 0.03), Vec3::x(), 0.003, "face");
    check(Vec3::new(0.005, -1.0, 0.053), Vec3::z(), 0.003, "above the top end, behind the plane");
    check(Vec3::new(0.005, 0.0, 0.017), -Vec3::z(), 0.003, "below the bottom end, behind the plane");
    let corner = Vec3::new(0.013, 0.2, 0.054);
    check(corner, Vec3::new(0.6, 0.0, 0.8), 0.005, "off the top corner");
    check(Vec3::new(0.013, 0.0, 0.016), Vec3::new(0.6, 0.0, -0.8), 0.005, "off the bottom corner");
    check(Vec3::new(0.009, 0.0, 0.03), Vec3::x(), -0.001, "inside, nearest the face");
    check(Vec3::new(0.0, 0.0, 0.0495), Vec3::z(), -0.0005, "inside, nearest the top");
    check(Vec3::new(0.0, 0.0, 0.0203), -Vec3::z(), -0.0003, "inside, nearest the bottom");
    // On an edge itself the face's normal stands in.
    assert_eq!(strip_profile_distance(0.05, 0.0, 0.02, 0.05), ([0.0, 1.0], 0.0));
    // Random points: outside, the foot x − gap·n is on the surface; |n| = 1.
    let mut seed = 99u64;
    let mut rand = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..1000 {
        let (s, h) = (-0.01 + 0.08 * rand(), -0.02 + 0.04 * rand());
        let (n, gap) = strip_profile_distance(s, h, 0.02, 0.05);
        assert!((n[0].hypot(n[1]) - 1.0).abs() < 1e-15);
        let (fs, fh) = (s - gap * n[0], h - gap * n[1]);
        let (_, on) = strip_profile_distance(fs, fh, 0.02, 0.05);
        assert!(on.abs() < 1e-15, "({s}, {h}): foot ({fs}, {fh}) is {on} off the surface");
        // Outside the slab the distance is the Euclidean one to the slab.
        let inside = h <= 0.0 && (0.02..=0.05).contains(&s);
        if !inside {
            let ds = (s - 0.05).max(0.02 - s).max(0.0);
            assert!((gap - ds.hypot(h.max(0.0))).abs() < 1e-15);
        } else {
            assert!(gap <= 0.0);
        }
    }
}

#[test]
fn bad_strips_are_refused_with_the_reason() {
    let err = |r: matdem_engine::Result<Wall>| r.unwrap_err().to_string();
    let e = err(Wall::strip("s", Vec3::zeros(), Vec3::x(), Vec3::new(1.0, 0.0, 1.0), 0.0, 1.0, 0.0));
    assert!(e.contains("axis must lie in the plane"), "{e}");
    let e = err(Wall::strip("s", Vec3::zeros(), Vec3::x(), Vec3::z(), 1.0, 0.5, 0.0));
    assert!(e.contains("lo < hi"), "{e}");
    let e = err(Wall::strip("s", Vec3::zeros(), Vec3::zeros(), Vec3::z(), 0.0, 1.0, 0.0));
    assert!(e.contains("non-zero"), "{e}");
    let e = err(Wall::strip("s", Vec3::new(f64::NAN, 0.0, 0.0), Vec3::x(), Vec3::z(), 0.0, 1.0, 0.0));
    assert!(e.contains("finite"), "{e}");
}

/// One grain of radius GRAIN at `x` against `wall`, held in place, no gravity; linear
/// contacts of Kn = 1e5 N/m (a rigid wall's spring is 2Kn), Ks = Kn, μ = 0.5, no dashpot.
fn grain_against(wall: Wall, x: Vec3) -> Model {
    let mut m = Model::new();
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

// A grain pressed 0.1 mm into the face, into the top end's face and into the top corner's edge:
// the force on it is 2Kn·δ along the surface's normal there, and the wall carries its reaction.
#[test]
fn grain_pressed_on_the_face_an_end_and_a_corner_feels_the_wall_law() {
    let delta = 1e-4;
    let edge = Vec3::new(0.01, 0.0, 0.05);
    let diag = Vec3::new(0.6, 0.0, 0.8);
    for (x, n, what) in [
        (Vec3::new(0.01 + GRAIN - delta, 0.0, 0.03), Vec3::x(), "face"),
        (Vec3::new(0.0, 0.0, 0.05 + GRAIN - delta), Vec3::z(), "top end"),
        (edge + diag * (GRAIN - delta), diag, "corner"),
    ] {
        let mut sim = Simulation::new(grain_against(side(), x));
        run(&mut sim, 1).unwrap();
        let want = n * (2.0 * KN * delta);
        let f = sim.model.particles.force[0];
        assert!(close(f, want, 1e-9) && rel(f.norm(), want.norm()) < 1e-9, "{what}: {f:?} vs {want:?}");
        let w = &sim.model.walls[0];
        assert_eq!(w.contacts, 1, "{what}");
        assert!(close(w.force, -want, 1e-9), "{what}: wall load {:?}", w.force);
    }
}

// A strip moving along its axis at 0.2 m/s past a grain held against its face: step for step the
// grain feels what it feels from a plane through the face moving alike (normal spring, shear
// spring and Coulomb cap with its history), to 1e-12, until the friction slides at μ·Fn.
#[test]
fn a_moving_strip_face_acts_as_a_moving_plane() {
    let x = Vec3::new(0.01 + GRAIN - 1e-4, 0.0, 0.035);
    let v = Vec3::new(0.0, 0.0, 0.2);
    let mut strip = side();
    strip.motion = WallMotion::Velocity(v);
    let mut plane = Wall::plane("side", Vec3::new(0.01, 0.0, 0.0), Vec3::x(), 0.0).unwrap();
    plane.motion = WallMotion::Velocity(v);
    let mut a = Simulation::new(grain_against(strip, x));
    let mut b = Simulation::new(grain_against(plane, x));
    for _ in 0..300 {
        run(&mut a, 1).unwrap();
        run(&mut b, 1).unwrap();
        let (fa, fb) = (a.model.particles.force[0], b.model.particles.force[0]);
        assert!(close(fa, fb, 1e-12), "strip {fa:?} vs plane {fb:?}");
    }
    // The shear spring reached the Coulomb cap: the wall drags the grain along v with μ·Fn.
    let f = a.model.particles.force[0];
    assert!(rel(f.z.abs(), 0.5 * f.x) < 1e-9 && f.z > 0.0, "capped shear {f:?}");
}

#[test]
fn a_strip_survives_a_checkpoint() {
    let m = grain_against(side(), Vec3::new(0.0105, 0.0, 0.03));
    let bytes = matdem_engine::checkpoint::encode(&m, &[]);
    let back = matdem_engine::checkpoint::decode(&bytes).unwrap().model;
    assert_eq!(back.walls[0].shape, m.walls[0].shape);
    assert!(matches!(back.walls[0].shape, WallShape::Strip { .. }));
}

/// The four sides of a shear box's half-boxes as strips (x-faces only): the lower box between
/// x = 0.01 and 0.03 up to z = 0.02, the upper box above it shifted 4 mm along +x and moving
/// on at 0.05 m/s. Grains held in place on the lower left and right faces, on the upper left
/// face, under the upper left side's bottom and off its corner; a free grain falls onto the
/// lower right side's top.
#[cfg(feature = "gpu")]
fn grains_between_half_box_sides() -> Model {
    let v = WallMotion::Velocity(Vec3::new(0.05, 0.0, 0.0));
    let strip = |name: &str, x: f64, normal: Vec3, lo: f64, hi: f64| {
        Wall::strip(name, Vec3::new(x, 0.0, 0.0), normal, Vec3::z(), lo, hi, 0.0).unwrap()
    };
    let mut upper_left = strip("upper_left", 0.014, Vec3::x(), 0.02, 0.1);
    let mut upper_right = strip("upper_right", 0.034, -Vec3::x(), 0.02, 0.1);
    upper_left.motion = v.clone();
    upper_right.motion = v;
    let mut m =
        grain_against(strip("lower_left", 0.01, Vec3::x(), -0.1, 0.02), Vec3::new(0.01 + GRAIN - 5e-5, 0.0, 0.01));
    m.add_wall(upper_left).unwrap();
    m.add_wall(strip("lower_right", 0.03, -Vec3::x(), -0.1, 0.02)).unwrap();
    m.add_wall(upper_right).unwrap();
    let mut add = |x: Vec3, fixed: bool| {
        let a = m.add_particle(x, GRAIN, 0).unwrap();
        if fixed {
            m.fix(&[a as u32], dof::ALL, true).unwrap();
        }
        a
    };
    add(Vec3::new(0.014 + GRAIN - 4e-5, 0.004, 0.03), true);
    add(Vec3::new(0.012, 0.008, 0.02 - GRAIN + 3e-5), true);
    add(Vec3::new(0.014 + 0.6 * (GRAIN - 2e-5), 0.012, 0.02 - 0.8 * (GRAIN - 2e-5)), true);
    add(Vec3::new(0.03 - GRAIN + 5e-5, 0.02, 0.01), true);
    let free = add(Vec3::new(0.032, 0.016, 0.02 + GRAIN + 2e-5), false);
    m.particles.vel[free] = Vec3::new(0.0, 0.0, -0.1);
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m
}

// The WGSL strips against the CPU's over 300 steps: each grain's force within 1e-3 of the
// largest force (f32 geometry), the walls' loads within 1e-3, the moving side where the CPU
// has it to 1e-9 m.
#[cfg(feature = "gpu")]
#[test]
fn gpu_strips_match_cpu() {
    let Some(ctx) = crate::common::gpu("gpu_strips") else { return };
    let model = grains_between_half_box_sides();
    let mut cpu = Simulation::new(model.clone());
    let mut gpu = Simulation::with_gpu(model, ctx);
    let mut most = [0u32; 4];
    for chunk in 0..6 {
        run(&mut cpu, 50).unwrap();
        run(&mut gpu, 50).unwrap();
        let (a, b) = (&cpu.model, &gpu.model);
        let scale = a.particles.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
        assert!(scale > 0.0);
        for (i, (fa, fb)) in a.particles.force.iter().zip(&b.particles.force).enumerate() {
            assert!((fa - fb).norm() <= 1e-3 * scale, "chunk {chunk}, grain {i}: cpu {fa:?} gpu {fb:?}");
        }
        for (wa, wb) in a.walls.iter().zip(&b.walls) {
            assert_eq!(wa.contacts, wb.contacts, "chunk {chunk}: {} contacts", wa.name);
            assert!((wa.force - wb.force).norm() <= 1e-3 * scale, "chunk {chunk}: {} load", wa.name);
            let (pa, pb) = match (&wa.shape, &wb.shape) {
                (WallShape::Strip { point: pa, .. }, WallShape::Strip { point: pb, .. }) => (*pa, *pb),
                _ => unreachable!(),
            };
            assert!((pa - pb).norm() < 1e-9, "{}: point {pa:?} vs {pb:?}", wa.name);
        }
        for (k, w) in a.walls.iter().enumerate() {
            most[k] = most[k].max(w.contacts);
        }
    }
    // Every kind of contact took part: the faces, the upper left's bottom and corner, the
    // lower right's top (the free grain landed on it, and bounces: no dashpot).
    assert_eq!(most, [1, 3, 2, 0], "most contacts per wall at the chunks' ends");
}
