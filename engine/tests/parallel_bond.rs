//! The `parallel_bond` stage (Potyondy & Cundall 2004; docs/parallel-bond.md) against analytic
//! answers: a bonded pair pulled, sheared, bent and twisted at a prescribed rate (stiffness and
//! breaking load of each), a cantilever of bonded spheres against Euler–Bernoulli, the energy of
//! an undamped bonded block, and two runs bit for bit.
//!
//! The pair tests drive the motion: both spheres get a mass of 1e30 kg, so that the bond's
//! loads change their velocities and spins by nothing measurable and the relative motion is
//! the one prescribed. Spheres of radius 1 mm, λ̄ = 1 (R̄ = 1 mm), Ē* = 1 GPa (k̄n = Ē*/2R =
//! 5e11 Pa/m), k̄* = 2, σ̄c = c̄ = 1 MPa, φ̄ = 30°: every bond breaks at a strain below 1e-2 rad
//! or 2e-6 m, where the geometry is still that of the start.

use crate::common::{material, rel};
use matdem_engine::backend::RunControl;
use matdem_engine::builder::simple_cubic;
use matdem_engine::effects::parallel_bond::physics::{BondState, ParallelBondParams};
use matdem_engine::physics::contact_law::BreakKind;
use matdem_engine::{Model, NormalKind, Simulation, Vec3};
use std::f64::consts::PI;

const R: f64 = 1e-3;
const HEAVY: f64 = 1e30;

fn params() -> ParallelBondParams {
    ParallelBondParams { lambda: 1.0, e_star: 1e9, k_ratio: 2.0, sigma_c: 1e6, cohesion: 1e6, phi: 30f64.to_radians() }
}

/// The bond's section: A, I, J and k̄n, k̄s of two spheres of radius R.
struct Section {
    area: f64,
    inertia: f64,
    polar: f64,
    kn: f64,
    ks: f64,
}

fn section(p: &ParallelBondParams) -> Section {
    let rb = p.lambda * R;
    let kn = p.e_star / (2.0 * R);
    Section { area: PI * rb * rb, inertia: PI * rb.powi(4) / 4.0, polar: PI * rb.powi(4) / 2.0, kn, ks: kn / p.k_ratio }
}

/// Two touching spheres on the x axis, parallel-bonded, both immovable by their loads.
fn heavy_pair(p: ParallelBondParams) -> Model {
    let mut m = Model::new();
    m.settings.normal = NormalKind::Linear;
    let k = m.add_material(material("m", 2650.0, 1e5, 1e8, 0.3)).unwrap();
    m.add_particle(Vec3::zeros(), R, k).unwrap();
    m.add_particle(Vec3::new(2.0 * R, 0.0, 0.0), R, k).unwrap();
    assert_eq!(m.connect(None, 1e-9).unwrap(), 1);
    assert_eq!(m.bond_parallel(p).unwrap(), 1);
    for i in 0..2 {
        m.particles.mass[i] = HEAVY;
    }
    m.set_dt(1e-6).unwrap();
    m
}

/// What a driven pair went through: the bond's state after each intact step, the relative
/// displacement and rotation (of sphere 1 from sphere 0) it was computed at, and the break.
struct Drive {
    states: Vec<BondState>,
    disp: Vec<Vec3>,
    rot: Vec<Vec3>,
    broke: Option<BreakKind>,
}

/// Steps the pair with velocities `v` and spins `w` (sphere 0, sphere 1) until the bond
/// breaks or `max` steps pass.
fn drive(p: ParallelBondParams, v: [Vec3; 2], w: [Vec3; 2], max: usize) -> Drive {
    let mut sim = Simulation::new(heavy_pair(p));
    let x0 = sim.model.particles.pos[1] - sim.model.particles.pos[0];
    let mut d = Drive { states: Vec::new(), disp: Vec::new(), rot: Vec::new(), broke: None };
    for k in 0..max {
        let m = &mut sim.model;
        m.particles.vel.copy_from_slice(&v);
        m.particles.rotation.as_mut().unwrap().ang_vel.copy_from_slice(&w);
        // The bond's update at this step sees the positions before the move; a new bond takes
        // no increment at its first step, so its load is that of the motion since.
        let disp = m.particles.pos[1] - m.particles.pos[0] - x0;
        sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
        let m = &sim.model;
        if let Some(b) = m.breakages.first() {
            d.broke = Some(b.kind);
            break;
        }
        d.states.push(m.parallel_bonds.state[0]);
        d.disp.push(disp);
        d.rot.push((w[1] - w[0]) * (m.clock.dt * k as f64));
    }
    d
}

// Pure tension: sphere 1 pulled along the axis at 1 mm/s (1 nm a step). Each step's normal
// force equals k̄n·A·δ (δ the opening since the bond was made) within 1e-9, on both rows
// alike; the bond breaks in tension at the step where F̄n/A first exceeds σ̄c, so the largest
// force it carried is σ̄c·A within one step's increment (5e-4 of it); tolerance 1 %.
#[test]
fn a_bond_in_pure_tension_has_stiffness_kn_a_and_breaks_at_sigma_c_a() {
    let p = params();
    let s = section(&p);
    let d = drive(p, [Vec3::zeros(), Vec3::new(1e-3, 0.0, 0.0)], [Vec3::zeros(); 2], 10_000);
    assert_eq!(d.broke, Some(BreakKind::Tension));
    let k = s.kn * s.area;
    for (st, x) in d.states.iter().zip(&d.disp).skip(1) {
        assert!(rel(st.normal, k * x.x) < 1e-9, "F̄n {} at δ {} (k̄nA·δ = {})", st.normal, x.x, k * x.x);
        assert!(st.shear.norm() < 1e-12 * st.normal && st.bending.norm() == 0.0 && st.twist == 0.0);
    }
    let peak = d.states.last().unwrap().normal;
    eprintln!("tension: k̄nA {k:.4e} N/m, peak {peak:.5} N, σ̄c·A {:.5} N", p.sigma_c * s.area);
    assert!(rel(peak, p.sigma_c * s.area) < 0.01);
}

// Pure shear: sphere 1 moved across the axis (y) at 1 mm/s, no spin. |F̄s| = k̄s·A·δs within
// 1e-6 (the axis tilts by δs/2R < 1e-3, which the rotated shear force follows to second
// order); the bond breaks in shear when |F̄s|/A exceeds c̄ − σ̄n·tan φ̄, σ̄n ≈ 0 (the pair opens
// by δs²/4R, 1e-9 m: σ̄n·tan φ̄ < 1e-3 c̄), so at c̄·A; tolerance 1 % on both.
#[test]
fn a_bond_in_pure_shear_has_stiffness_ks_a_and_breaks_at_c_a() {
    let p = params();
    let s = section(&p);
    let d = drive(p, [Vec3::zeros(), Vec3::new(0.0, 1e-3, 0.0)], [Vec3::zeros(); 2], 10_000);
    assert_eq!(d.broke, Some(BreakKind::Shear));
    let k = s.ks * s.area;
    for (st, x) in d.states.iter().zip(&d.disp).skip(1) {
        assert!(rel(st.shear.norm(), k * x.y) < 1e-6, "|F̄s| {} at δs {}", st.shear.norm(), x.y);
        assert!(st.shear.y < 0.0, "the shear force resists the motion");
    }
    let peak = d.states.last().unwrap().shear.norm();
    eprintln!("shear: k̄sA {k:.4e} N/m, peak {peak:.5} N, c̄·A {:.5} N", p.cohesion * s.area);
    assert!(rel(peak, p.cohesion * s.area) < 0.01);
}

// Pure bending: the spheres spun in opposite senses about z at 0.5 rad/s each (their surfaces
// at the bond move together: no shear), the relative rotation θ growing by 1e-6 rad a step.
// |M̄b| = k̄n·I·θ within 1e-9; the bond breaks in tension when |M̄b|·R̄/I exceeds σ̄c, at
// M̄b = σ̄c·I/R̄; tolerance 1 %.
#[test]
fn a_bond_in_pure_bending_has_stiffness_kn_i_and_breaks_at_sigma_c_i_over_r() {
    let p = params();
    let s = section(&p);
    let w = Vec3::new(0.0, 0.0, 0.5);
    let d = drive(p, [Vec3::zeros(); 2], [-w, w], 100_000);
    assert_eq!(d.broke, Some(BreakKind::Tension));
    let k = s.kn * s.inertia;
    for (st, th) in d.states.iter().zip(&d.rot).skip(1) {
        assert!(rel(st.bending.norm(), k * th.z) < 1e-9, "|M̄b| {} at θ {}", st.bending.norm(), th.z);
        assert!(st.shear.norm() < 1e-9 * st.bending.norm() / R, "bending must not shear the bond");
    }
    let peak = d.states.last().unwrap().bending.norm();
    let expected = p.sigma_c * s.inertia / (p.lambda * R);
    eprintln!("bending: k̄nI {k:.4e} N·m/rad, peak {peak:.5e} N·m, σ̄c·I/R̄ {expected:.5e} N·m");
    assert!(rel(peak, expected) < 0.01);
}

// Pure twisting: sphere 1 spun about the axis at 1 rad/s (1e-6 rad a step). |M̄t| = k̄s·J·θ
// within 1e-9; the bond breaks in shear when |M̄t|·R̄/J exceeds c̄ (σ̄n = 0), at M̄t = c̄·J/R̄;
// tolerance 1 %.
#[test]
fn a_bond_in_pure_twisting_has_stiffness_ks_j_and_breaks_at_c_j_over_r() {
    let p = params();
    let s = section(&p);
    let d = drive(p, [Vec3::zeros(); 2], [Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0)], 100_000);
    assert_eq!(d.broke, Some(BreakKind::Shear));
    let k = s.ks * s.polar;
    for (st, th) in d.states.iter().zip(&d.rot).skip(1) {
        assert!(rel(st.twist.abs(), k * th.x) < 1e-9, "|M̄t| {} at θ {}", st.twist, th.x);
        assert!(st.twist < 0.0 && st.shear.norm() == 0.0 && st.normal == 0.0);
    }
    let peak = d.states.last().unwrap().twist.abs();
    let expected = p.cohesion * s.polar / (p.lambda * R);
    eprintln!("twisting: k̄sJ {k:.4e} N·m/rad, peak {peak:.5e} N·m, c̄·J/R̄ {expected:.5e} N·m");
    assert!(rel(peak, expected) < 0.01);
}

// A compressive normal force raises the shear strength to c̄ + |σ̄n|·tan φ̄: the pair first
// pushed together by 0.5 µm (σ̄n = −k̄n·δ = −0.25 MPa), then sheared, breaks at
// (c̄ + 0.25 MPa·tan 30°)·A; tolerance 1 %.
#[test]
fn compression_raises_the_shear_strength_by_sigma_tan_phi() {
    let p = params();
    let s = section(&p);
    let mut sim = Simulation::new(heavy_pair(p));
    let push = 0.5e-6;
    let steps = 500;
    sim.model.particles.vel[1] = Vec3::new(-push / (steps as f64 * 1e-6), 0.0, 0.0);
    sim.run(steps + 1, &RunControl::default(), &mut |_| {}).unwrap();
    let sigma = sim.model.parallel_bonds.state[0].normal / s.area;
    assert!(rel(sigma, -s.kn * push) < 1e-3, "σ̄n {sigma:e}");
    sim.model.particles.vel[1] = Vec3::new(0.0, 1e-3, 0.0);
    let mut peak = 0.0;
    for _ in 0..20_000 {
        sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
        if !sim.model.breakages.is_empty() {
            break;
        }
        peak = sim.model.parallel_bonds.state[0].shear.norm();
    }
    assert_eq!(sim.model.breakages[0].kind, BreakKind::Shear);
    let expected = (p.cohesion - sigma * p.phi.tan()) * s.area;
    eprintln!("shear under σ̄n {sigma:.3e} Pa: peak {peak:.5} N, (c̄ − σ̄n·tan φ̄)·A {expected:.5} N");
    assert!(rel(peak, expected) < 0.01);
}

// A broken bond leaves the plain linear contact: after the tension test's break the pair
// carries no load while apart, and pushed back into contact it meets the contact's kn.
#[test]
fn a_broken_bond_leaves_the_linear_contact() {
    let p = params();
    let mut sim = Simulation::new(heavy_pair(p));
    sim.model.particles.vel[1] = Vec3::new(1e-2, 0.0, 0.0);
    sim.run(400, &RunControl::default(), &mut |_| {}).unwrap();
    assert_eq!(sim.model.breakages.len(), 1);
    assert_eq!(sim.model.parallel_bonds.intact(), 0);
    assert_eq!(sim.model.particles.force[1], Vec3::zeros(), "apart and unbonded: no force");
    // Back into an overlap of 1 µm: the linear contact's kn·δ (kn 1e5 N/m: 0.1 N).
    let x1 = Vec3::new(2.0 * R - 1e-6, 0.0, 0.0);
    sim.model.particles.pos[1] = x1;
    sim.model.particles.vel[1] = Vec3::zeros();
    sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
    let f = sim.model.particles.force[1];
    assert!(rel(f.x, 1e5 * 1e-6) < 1e-6, "contact force {f:?}");
}

/// A row of `n` spheres along x, `gap` apart, parallel-bonded, the first clamped (fixed in
/// translation, and too heavy to turn), under gravity −z, with viscous damping.
fn cantilever(n: usize, gap: f64) -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, 1e5, 1e8, 0.3)).unwrap();
    for i in 0..n {
        m.add_particle(Vec3::new(i as f64 * (2.0 * R + gap), 0.0, 0.0), R, k).unwrap();
    }
    assert_eq!(m.connect(None, 2.0 * gap).unwrap(), n - 1);
    let p = ParallelBondParams { sigma_c: 1e12, cohesion: 1e12, ..params() };
    m.bond_parallel(p).unwrap();
    m.fix(&[0], matdem_engine::state::particles::dof::ALL, true).unwrap();
    m.particles.mass[0] = HEAVY;
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m
}

// Euler–Bernoulli: a cantilever of 20 bonded spheres (clamp at sphere 0's centre, L = 19·a,
// a = 2R + gap the spacing), each sphere's weight a point load P at x_j = j·a: the tip
// deflects by Σ P·x_j²·(3L − x_j)/(6·EI), with the chain's bending stiffness EI = k̄n·I·a
// (a bond turns by M/(k̄n·I) over a length a). The chain differs from the beam by its
// discreteness (rotations exact at the nodes, deflection by the trapezoid rule: ≈ 1/(4N²))
// and by the bonds' shear compliance (≈ 3k̄*λ̄²/(16N²) of the bending deflection), 0.2 % in
// all at N = 19; tolerance 1 %. Viscous damping brings the beam to rest (tip speed checked).
#[test]
fn a_bonded_cantilever_deflects_as_euler_bernoulli() {
    let (n, gap) = (20, 1e-7);
    let mut m = cantilever(n, gap);
    let a = 2.0 * R + gap;
    let p = params();
    let s = section(&p);
    let ei = s.kn * s.inertia * a;
    let w = m.particles.mass[1] * 9.81;
    let l = (n - 1) as f64 * a;
    let expected: f64 = (1..n).map(|j| j as f64 * a).map(|x| w * x * x * (3.0 * l - x) / (6.0 * ei)).sum();
    // The fundamental mode, ω₁ = 1.875²·√(EI/(μL⁴)), damped at 0.75 of critical (c/m = 1.5·ω₁:
    // every mode decays at least as e^(−0.75·ω₁·t)), for 20/ω₁.
    let mu = m.particles.mass[1] / a;
    let omega = 1.875f64.powi(2) * (ei / (mu * l.powi(4))).sqrt();
    let k_el = m.element_stiffness(1);
    m.settings.damping = 0.75 * omega / (k_el / m.particles.mass[1]).sqrt();
    m.set_dt(1e-7).unwrap();
    let mut sim = Simulation::new(m);
    let steps = (20.0 / omega / 1e-7) as u64;
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
    let tip = sim.model.particles.pos[n - 1].z;
    let speed = sim.model.particles.vel[n - 1].norm();
    eprintln!(
        "cantilever of {n}: EI {ei:.4e} N·m², ω₁ {omega:.0} rad/s, {steps} steps; tip deflection {:.5e} m, \
         Euler–Bernoulli {expected:.5e} m ({:+.3} %), tip speed {speed:.1e} m/s",
        -tip,
        100.0 * (-tip / expected - 1.0)
    );
    assert!(speed / omega < 1e-4 * expected, "the beam is still moving");
    assert!(rel(-tip, expected) < 0.01);
}

/// A 3 × 3 × 3 simple-cubic block of spheres 0.1 µm apart, parallel-bonded to its 54 nearest
/// pairs, strengths out of reach, given pseudo-random velocities and spins.
fn shaken_block() -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, 1e5, 1e8, 0.3)).unwrap();
    for x in simple_cubic(3, 3, 3, 2.0 * R + 1e-7, Vec3::zeros()) {
        m.add_particle(x, R, k).unwrap();
    }
    assert_eq!(m.connect(None, 2e-7).unwrap(), 54);
    let p = ParallelBondParams { sigma_c: 1e12, cohesion: 1e12, ..params() };
    m.bond_parallel(p).unwrap();
    let wave = |i: usize, c: usize| ((i * 7 + c * 13) % 11) as f64 / 11.0 - 0.5;
    for i in 0..m.len() {
        m.particles.vel[i] = Vec3::new(wave(i, 0), wave(i, 1), wave(i, 2)) * 1e-3;
        m.particles.rotation.as_mut().unwrap().ang_vel[i] = Vec3::new(wave(i, 3), wave(i, 4), wave(i, 5));
    }
    m.set_dt(2e-8).unwrap();
    m
}

// With the bonds intact and no damping, kinetic (translation and spin) + the bonds' elastic
// energy is constant: a shaken 27-sphere block, 20 000 steps (about 30 periods of its
// stiffest modes), sampled every 20 steps. The leapfrog estimate fluctuates by (ω·dt)²/8 of a
// mode's energy (ω·dt < 0.03 here: 1e-4); the largest deviation of any sample from the first is
// within 1e-3, and the mean of the last 100 samples within 1e-4 of the first 100's. No bond
// breaks; the elastic share shows the bonds were loaded.
#[test]
fn energy_is_conserved_with_parallel_bonds_intact() {
    let mut sim = Simulation::new(shaken_block());
    let mut log = Vec::new();
    sim.run_sampled(20_000, 20, &RunControl::default(), &mut |_| {}, &mut |s| log.push(s.energies)).unwrap();
    let total: Vec<f64> = log.iter().map(|e| e.total()).collect();
    let e0 = total[0];
    let worst = total.iter().map(|e| (e / e0 - 1.0).abs()).fold(0.0, f64::max);
    let mean = |w: &[f64]| w.iter().sum::<f64>() / w.len() as f64;
    let drift = (mean(&total[total.len() - 100..]) / mean(&total[..100]) - 1.0).abs();
    let end = log.last().unwrap();
    let share = (end.normal_elastic + end.shear_elastic) / end.mechanical();
    eprintln!(
        "bonded block: {} samples, energy {e0:.4e} J, largest deviation {worst:.2e}, drift {drift:.2e}, \
         elastic share at the end {share:.2}",
        log.len()
    );
    assert!(sim.model.breakages.is_empty());
    assert!(share > 0.1, "the bonds must take up energy");
    assert!(worst < 1e-3, "energy deviates by {worst:e}");
    assert!(drift < 1e-4, "energy drifts by {drift:e}");
}

// Two runs of the shaken block, one on the global thread pool and one on a single thread,
// give the same positions, velocities, spins and bond states, bit for bit.
#[test]
fn parallel_bonds_are_bitwise_deterministic() {
    let run = || {
        let mut sim = Simulation::new(shaken_block());
        sim.run(2_000, &RunControl::default(), &mut |_| {}).unwrap();
        sim.model
    };
    let a = run();
    let b = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(run);
    assert_eq!(a.particles.pos, b.particles.pos);
    assert_eq!(a.particles.vel, b.particles.vel);
    assert_eq!(a.particles.rotation.as_ref().unwrap().ang_vel, b.particles.rotation.as_ref().unwrap().ang_vel);
    assert_eq!(a.parallel_bonds.state, b.parallel_bonds.state);
    // Both rows of every bond hold the same state.
    let pb = &a.parallel_bonds;
    for i in 0..a.len() {
        for e in pb.row(i) {
            let j = pb.other[e] as usize;
            let back = pb.row(j).find(|&f| pb.other[f] as usize == i).unwrap();
            assert_eq!(pb.state[e], pb.state[back]);
        }
    }
}

/// One backend's driven pair: the bond's state at the end of each chunk, and its break (step, kind).
#[cfg(feature = "gpu")]
type Driven = (Vec<BondState>, Option<(u64, BreakKind)>);

/// The pair of the stiffness tests driven `steps` steps in chunks of `chunk` on both backends
/// (CPU first).
#[cfg(feature = "gpu")]
fn driven_on_both(
    ctx: &std::sync::Arc<matdem_engine::backend::gpu::device::GpuContext>,
    v: [Vec3; 2],
    w: [Vec3; 2],
    steps: u64,
    chunk: u64,
) -> [Driven; 2] {
    let mut m = heavy_pair(params());
    m.particles.vel.copy_from_slice(&v);
    m.particles.rotation.as_mut().unwrap().ang_vel.copy_from_slice(&w);
    let sims = [Simulation::new(m.clone()), Simulation::with_gpu(m, ctx.clone())];
    sims.map(|mut sim| {
        let mut states = Vec::new();
        for _ in 0..steps / chunk {
            sim.run(chunk, &RunControl::default(), &mut |_| {}).unwrap();
            states.push(sim.model.parallel_bonds.state[0]);
        }
        (states, sim.model.breakages.first().map(|b| (b.step, b.kind)))
    })
}

// GPU parity, pairs: the four driven pairs (tension, shear, bending, twisting) on both backends,
// 5000 steps in chunks of 500 (the bonds break after 2000 to 4000 steps). Every intact state the
// CPU (f64) reached, the GPU (f32) reached within 1e-4 of the load's magnitude; the bond breaks
// the same way, within 2 steps of the CPU's step (f32's increments round differently).
#[cfg(feature = "gpu")]
#[test]
fn gpu_parity_of_driven_bonded_pairs() {
    let Some(ctx) = crate::common::gpu("parallel_bond_pairs") else { return };
    let (z, x) = (Vec3::zeros(), Vec3::x());
    let cases = [
        ("tension", [z, x * 1e-3], [z, z]),
        ("shear", [z, Vec3::y() * 1e-3], [z, z]),
        ("bending", [z, z], [Vec3::z() * -0.5, Vec3::z() * 0.5]),
        ("twisting", [z, z], [z, x * 1.0]),
    ];
    for (name, v, w) in cases {
        let [(cpu, cpu_break), (gpu, gpu_break)] = driven_on_both(&ctx, v, w, 5000, 500);
        let scale = |s: &BondState| s.normal.abs() + s.shear.norm() + (s.bending.norm() + s.twist.abs()) / R;
        let mut worst = 0.0f64;
        for (a, b) in cpu.iter().zip(&gpu).filter(|(a, _)| a.intact()) {
            assert!(b.intact(), "{name}: the GPU's bond broke early");
            let diff = BondState {
                shear: a.shear - b.shear,
                normal: a.normal - b.normal,
                bending: a.bending - b.bending,
                twist: a.twist - b.twist,
                status: 0,
            };
            worst = worst.max(scale(&diff) / scale(a));
        }
        let (cs, ck) = cpu_break.expect("the CPU's bond breaks");
        let (gs, gk) = gpu_break.expect("the GPU's bond breaks");
        eprintln!("{name}: worst difference {worst:.2e} of the load; broke at step {cs} (cpu) and {gs} (gpu)");
        assert!(worst < 1e-4, "{name}: {worst:e}");
        assert_eq!(ck, gk, "{name}: break kind");
        assert!(cs.abs_diff(gs) <= 2, "{name}: breaks at steps {cs} and {gs}");
    }
}

/// A 3 × 3 × 3 parallel-bonded block whose bottom layer is held and whose top layer is pulled
/// up at 2 m/s: the top plane of bonds breaks in tension within about 50 steps, before the
/// stress wave has crossed the block.
#[cfg(feature = "gpu")]
fn pulled_block() -> Model {
    let mut m = shaken_block();
    for i in 0..m.len() {
        m.particles.vel[i] = Vec3::zeros();
        m.particles.rotation.as_mut().unwrap().ang_vel[i] = Vec3::zeros();
    }
    let z = |m: &Model, i: usize| m.particles.pos[i].z;
    let top: Vec<u32> = (0..m.len()).filter(|&i| z(&m, i) > 3.0 * R).map(|i| i as u32).collect();
    let bottom: Vec<u32> = (0..m.len()).filter(|&i| z(&m, i) < R).map(|i| i as u32).collect();
    // Breakable bonds: the pair tests' strengths (1 MPa).
    m.parallel_bonds.params = Some(params());
    m.fix(&top, matdem_engine::state::particles::dof::ALL, true).unwrap();
    m.fix(&bottom, matdem_engine::state::particles::dof::ALL, true).unwrap();
    for &i in &top {
        m.particles.vel[i as usize] = Vec3::new(0.0, 0.0, 2.0);
    }
    m
}

// GPU parity, a bonded block loaded to breaking: the pulled block on both backends, 200 steps.
// The same nine bonds (the top plane's) break, in tension, each within 2 steps of the CPU's
// step; no other breaks; positions agree within 1e-3 of the pull's travel (f32).
#[cfg(feature = "gpu")]
#[test]
fn gpu_parity_of_a_bonded_block_pulled_to_breaking() {
    let Some(ctx) = crate::common::gpu("parallel_bond_block") else { return };
    let m = pulled_block();
    let mut cpu = Simulation::new(m.clone());
    let mut gpu = Simulation::with_gpu(m, ctx);
    for sim in [&mut cpu, &mut gpu] {
        sim.run(200, &RunControl::default(), &mut |_| {}).unwrap();
    }
    let key = |s: &Simulation| {
        let mut b: Vec<_> =
            s.model.breakages.iter().map(|b| (b.i, b.j, b.kind == BreakKind::Tension, b.step)).collect();
        b.sort();
        b
    };
    let (a, b) = (key(&cpu), key(&gpu));
    eprintln!("pulled block: cpu breaks {a:?}\n              gpu breaks {b:?}");
    assert_eq!(a.len(), 9, "the top plane's nine bonds break");
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!((x.0, x.1, x.2), (y.0, y.1, y.2));
        assert!(x.3.abs_diff(y.3) <= 2, "bond {}–{} breaks at {} and {}", x.0, x.1, x.3, y.3);
    }
    let travel = 2.0 * 200.0 * cpu.model.clock.dt;
    let worst = (0..cpu.model.len())
        .map(|i| (cpu.model.particles.pos[i] - gpu.model.particles.pos[i]).norm())
        .fold(0.0, f64::max);
    eprintln!("pulled block: largest position difference {:.2e} of the travel", worst / travel);
    assert!(worst < 1e-3 * travel);
}
