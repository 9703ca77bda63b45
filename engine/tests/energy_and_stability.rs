//! Energy bookkeeping and stability at MatDEM's standard time step, through the full engine
//! (model → plan → CPU backend → guard).
//!
//! Reference: /work/shared/reference/physics.md §2 ("with no damping and no breakage, kinetic,
//! elastic and gravitational energy sum to a constant; with breakage or damping, that sum plus
//! the heat released is constant"). Walls that move do work on the particles, so the conserved
//! quantity of a scene with a platen is `Energies::total()` = mechanical + heat − wall work.
//!
//! How energy is measured: `Simulation::run_sampled` reports, at integer step n, the elastic
//! and gravitational energy at the positions x_n and the kinetic energy of the mean of the two
//! half-step (leapfrog) velocities. That estimate is exact at rest, but while the scene
//! vibrates it exceeds the energy the leapfrog scheme conserves by m·|a|²·dt²/8 per element,
//! up to (ω·dt)²/8 of each mode's energy: for the undamped block below 5e-3 on average, but
//! 0 in the first sample (no spring loaded yet), and single samples scatter by up to 2e-3.
//! Where the motion never stops, drift is therefore measured on means over many samples;
//! where it does, at rest, and all samples are checked only against looser or physical
//! bounds (the energy account never rising above its start).
//!
//! Run with `cargo test -p matdem-engine --release --test energy_and_stability -- --nocapture`
//! to see the measured values.

use matdem_engine::backend::RunControl;
use matdem_engine::builder::{fcc_111_block, BoxSpec, Container, Rng, SizeClass};
use matdem_engine::simulation::EnergySample;
use matdem_engine::{Balance, MacroProperties, Material, Model, Simulation, Vec3, Wall, WallMotion};
use std::time::Instant;

/// Element diameter of the lattice scenes (m).
const D: f64 = 1e-3;

/// A rock-like material from macro properties (E 1 GPa, ν 0.1) on elements of diameter `D`.
fn rock(tensile: f64) -> Material {
    let p = MacroProperties { young: 1e9, poisson: 0.1, tensile, compressive: 10.0 * tensile, internal_friction: 0.6 };
    Material::from_macro("rock", 2600.0, &p, D).unwrap()
}

/// An n × n × n FCC block (close-packed layers along z), every touching pair bonded.
fn bonded_block(n: usize, mat: Material) -> Model {
    let mut m = Model::new();
    m.add_material(mat).unwrap();
    for p in fcc_111_block(n, n, n, D) {
        m.add_particle(p, D / 2.0, 0).unwrap();
    }
    let bonds = m.connect(None, 0.01 * D).unwrap();
    assert!(bonds > 4 * m.len(), "the block should be fully bonded ({bonds} bonds)");
    m
}

/// Runs `steps` steps, appending an energy sample every `every` steps to `log`. A stability
/// guard error (non-finite state, runaway speed, deep overlap) fails the test with its message.
fn run_logged(sim: &mut Simulation, steps: u64, every: u64, log: &mut Vec<EnergySample>) {
    if let Err(e) = sim.run_sampled(steps, every, &RunControl::default(), &mut |_| {}, &mut |s| log.push(s)) {
        panic!("the stability guard stopped the run: {e}");
    }
}

/// Largest rise of mechanical + heat − wall work above its first sample (J).
fn max_growth(log: &[EnergySample]) -> f64 {
    let e0 = log[0].energies.total();
    log.iter().map(|s| s.energies.total() - e0).fold(f64::MIN, f64::max)
}

/// Every position, velocity and force is finite, every centre lies inside every wall (on
/// the side its normal points to); returns the smallest centre-to-wall gap over the radius.
fn assert_finite_and_inside_walls(m: &Model) -> f64 {
    let p = &m.particles;
    let mut min_gap = f64::INFINITY;
    for i in 0..p.len() {
        let finite = p.pos[i].iter().chain(p.vel[i].iter()).chain(p.force[i].iter()).all(|c| c.is_finite());
        assert!(finite, "particle {i} has a non-finite state");
        for w in &m.walls {
            let (_, gap) = w.normal_and_distance(&p.pos[i]);
            assert!(gap > 0.0, "particle {i} (centre {:?}) is outside wall `{}`", p.pos[i], w.name);
            min_gap = min_gap.min(gap / p.radius[i]);
        }
    }
    min_gap
}

/// Deepest overlap between two particles, as a fraction of the smaller radius.
fn max_overlap_ratio(m: &Model) -> f64 {
    matdem_engine::guard::deepest_overlap(m).map_or(0.0, |d| d.share)
}

/// Plane walls around the box [lo, hi]: floor, four sides and, if given, a lid at `lid` z.
fn add_box_walls(m: &mut Model, lo: Vec3, hi: Vec3, lid: Option<f64>) {
    let (lx, ly) = (hi.x - lo.x, hi.y - lo.y);
    let walls = [
        ("floor", lo, Vec3::z(), lx * ly),
        ("left", lo, Vec3::x(), ly * (hi.z - lo.z)),
        ("right", hi, -Vec3::x(), ly * (hi.z - lo.z)),
        ("front", lo, Vec3::y(), lx * (hi.z - lo.z)),
        ("back", hi, -Vec3::y(), lx * (hi.z - lo.z)),
    ];
    for (name, point, normal, area) in walls {
        m.add_wall(Wall::plane(name, point, normal, area).unwrap()).unwrap();
    }
    if let Some(z) = lid {
        let lid = Wall::plane("lid", Vec3::new(lo.x, lo.y, z), -Vec3::z(), lx * ly).unwrap();
        m.add_wall(lid).unwrap();
    }
}

/// Bounding box of the particles, spheres included.
fn bounds(m: &Model) -> (Vec3, Vec3) {
    let p = &m.particles;
    let (mut lo, mut hi) = (Vec3::repeat(f64::MAX), Vec3::repeat(f64::MIN));
    for i in 0..p.len() {
        lo = lo.inf(&(p.pos[i] - Vec3::repeat(p.radius[i])));
        hi = hi.sup(&(p.pos[i] + Vec3::repeat(p.radius[i])));
    }
    (lo, hi)
}

// physics.md §2: with no damping and no breakage, kinetic + elastic energy is constant.
// Scene: a 6×6×6 bonded FCC block (216 elements, 967 bonds; linear law, shear springs,
// rotation on) given random velocities of up to 0.1 m/s with zero mean and no walls, no
// dashpot, no viscous damping, strengths far above the loads. 1e5 steps at the standard
// step, sampled every 10 steps. The block vibrates through thousands of periods, trading
// kinetic for elastic energy (checked: the kinetic share falls from ~1 to about 1/2).
// Drift = |mean of the last 1000 samples − mean of the first 1000| / mean of the first
// 1000 (each window spans 1e4 steps, averaging the leapfrog estimate's fluctuation, see the
// header; the low first sample moves the first mean by 5e-6); tolerance 1e-4. Also: no
// heat of any kind is booked and no bond breaks.
#[test]
fn energy_is_conserved_without_damping_or_breakage() {
    let mut m = bonded_block(6, rock(1e9));
    m.settings.rotation = true;
    let bonds = m.bond_count();
    let mut rng = Rng::new(7);
    let n = m.len();
    let mut v: Vec<Vec3> =
        (0..n).map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()).map(|c| 0.2 * (c - 0.5))).collect();
    let mean = v.iter().sum::<Vec3>() / n as f64;
    for (i, vi) in v.iter_mut().enumerate() {
        *vi -= mean;
        m.particles.vel[i] = *vi;
    }
    let dt = m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    let mut log = Vec::new();
    let t0 = Instant::now();
    run_logged(&mut sim, 100_000, 10, &mut log);
    let secs = t0.elapsed().as_secs_f64();

    let total: Vec<f64> = log.iter().map(|s| s.energies.total()).collect();
    let mean = |w: &[f64]| w.iter().sum::<f64>() / w.len() as f64;
    let (first, last) = (mean(&total[..1000]), mean(&total[total.len() - 1000..]));
    let drift = (last - first).abs() / first;
    let spread = total[1..].iter().map(|e| (e / first - 1.0).abs()).fold(0.0, f64::max);
    let end = log.last().unwrap().energies;
    let ke_share = end.kinetic / end.mechanical();
    eprintln!(
        "undamped bonded block: {n} elements, dt {dt:.3e} s, {} samples in {secs:.1} s; \
         drift of the 1000-sample means {drift:.2e}; largest single-sample deviation {spread:.2e} \
         (first sample {:+.2e}); kinetic share at the end {ke_share:.3}",
        log.len(),
        total[0] / first - 1.0
    );
    assert!(drift < 1e-4, "energy drift {drift:e}");
    assert!((0.2..0.8).contains(&ke_share), "the block must trade kinetic for elastic energy");
    assert_eq!(end.heat(), 0.0, "no heat without damping, friction or breakage");
    assert_eq!(end.wall_work, 0.0);
    assert_eq!(sim.model.bond_count(), bonds, "no bond may break");
}

// physics.md §2: with breakage or damping, mechanical energy plus the heat released is
// constant; a moving platen adds its work (Energies::total = mechanical + heat − wall work).
// Scene: an 8×8×8 bonded FCC block (512 elements; E 1 GPa, ν 0.1, Tu 1 MPa, Cu 10 MPa,
// μi 0.6) on a fixed floor under gravity, viscous damping 0.01 of critical, crushed by a
// platen moving down at 2 m/s for 4000 steps, which then stops; 10000 more steps let the
// debris come to rest. The block starts at rest, so the energy scale is what entered
// through the platen, its work W. Tolerance: |total() − total() of the first sample| < 1e-3·W
// at every sample (every 10 steps), including at rest at the end. heat_breakage,
// heat_damping and heat_friction must all be positive, and more than half the bonds break.
#[test]
fn energy_plus_heat_is_conserved_with_damping_and_breakage() {
    let mut m = bonded_block(8, rock(1e6));
    let bonds0 = m.bond_count();
    let top = m.particles.pos.iter().map(|p| p.z).fold(f64::MIN, f64::max);
    let floor = Wall::plane("floor", Vec3::new(0.0, 0.0, -D / 2.0), Vec3::z(), 1e-4).unwrap();
    m.add_wall(floor).unwrap();
    let mut platen = Wall::plane("platen", Vec3::new(0.0, 0.0, top + D / 2.0), -Vec3::z(), 1e-4).unwrap();
    platen.motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -2.0));
    m.add_wall(platen).unwrap();
    m.settings.damping = 0.01;
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    let mut log = Vec::new();
    let t0 = Instant::now();
    run_logged(&mut sim, 4000, 10, &mut log);
    sim.model.wall_mut("platen").unwrap().motion = WallMotion::Fixed;
    run_logged(&mut sim, 10_000, 10, &mut log);
    let secs = t0.elapsed().as_secs_f64();

    let e0 = log[0].energies.total();
    let end = log.last().unwrap().energies;
    let scale = end.wall_work;
    let worst = log.iter().map(|s| (s.energies.total() - e0).abs()).fold(0.0, f64::max) / scale;
    let at_rest = (end.total() - e0).abs() / scale;
    let broken = bonds0 - sim.model.bond_count();
    eprintln!(
        "crushed block: {broken} of {bonds0} bonds broke; platen work {scale:.3e} J went to heat: \
         damping {:.3}, breakage {:.3}, friction {:.3}, left in motion {:.1e}; \
         |Δ total| largest {worst:.2e}, at rest {at_rest:.2e} of the work ({secs:.1} s)",
        end.heat_damping / scale,
        end.heat_breakage / scale,
        end.heat_friction / scale,
        end.kinetic / scale
    );
    assert!(end.heat_breakage > 0.0 && broken > bonds0 / 2, "bonds must break");
    assert!(end.heat_damping > 0.0 && end.heat_friction > 0.0);
    assert!(end.kinetic < 1e-6 * scale, "the debris should be at rest");
    assert!(worst < 1e-3, "energy account off by {worst:e} of the work done");
    assert_finite_and_inside_walls(&sim.model);
}

// Hard case: a 1:10 gradation. MatDEM's box builder fills a 12 × 12 mm box with radii
// 0.10–0.15 mm (2% of the mass, ~400 grains) and 0.8–1.0 mm (~55 grains); linear contacts
// Kn 100 N/m, Ks 40 N/m, μp 0.5, restitution 0.3. The grains fall under gravity with light
// viscous damping (1e-4: scaled to each grain's critical damping, more would hold the
// smallest grains in the air, their terminal speed being ∝ 1/damping) for 40000 steps,
// then settle with damping 0.05 for 20000 more, all at the standard step (set by the
// smallest grain). Checks: the guard never fires, no NaN, every centre inside the box, the
// energy account never rises above its start by more than 1e-3 of the initial
// (gravitational) energy, and the sample settles (kinetic energy < 1e-3 of it).
#[test]
fn wide_gradation_1_to_10_deposits_stably() {
    let mut m = Model::new();
    let mut mat = Material::from_micro("sand", 2650.0, 100.0, 40.0, 0.0, 0.0, 0.5, 1e-3).unwrap();
    mat.restitution = 0.3;
    m.add_material(mat).unwrap();
    let spec = BoxSpec {
        container: Container::Cuboid { width: 0.012, length: 0.012 },
        height: 0.002,
        classes: vec![
            SizeClass { r_min: 1e-4, r_max: 1.5e-4, mass_ratio: 0.02 },
            SizeClass { r_min: 0.8e-3, r_max: 1e-3, mass_ratio: 1.0 },
        ],
        target_porosity: 0.4,
        seed: 3,
        top_platen: false,
    };
    let built = spec.build_into(&mut m).unwrap();
    let (small, large) = (built.class_ids[0].len(), built.class_ids[1].len());
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m.settings.damping = 1e-4;
    let dt = m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    let mut log = Vec::new();
    let t0 = Instant::now();
    run_logged(&mut sim, 40_000, 100, &mut log);
    sim.model.settings.damping = 0.05;
    run_logged(&mut sim, 20_000, 100, &mut log);
    let secs = t0.elapsed().as_secs_f64();

    let e0 = log[0].energies.total();
    let end = log.last().unwrap().energies;
    let growth = max_growth(&log) / e0;
    let min_gap = assert_finite_and_inside_walls(&sim.model);
    eprintln!(
        "1:10 gradation: {small} small + {large} large grains, dt {dt:.3e} s, {secs:.1} s; \
         gravitational energy released {:.3}, kinetic left {:.1e}, energy account rose by at most \
         {growth:.1e} (end {:+.1e}); closest centre to a wall {min_gap:.2} radii",
        1.0 - end.gravity / e0,
        end.kinetic / e0,
        end.total() / e0 - 1.0
    );
    assert!(growth < 1e-3, "energy grew by {growth:e} of the initial energy");
    assert!(end.gravity < 0.8 * e0, "the grains must have fallen");
    assert!(end.kinetic < 1e-3 * e0, "the deposit should be settling");
}

/// Two materials with normal springs 1e4 and 1e7 N/m (Ks = 0.4·Kn, μp 0.5), same density.
fn soft_and_stiff() -> (Material, Material) {
    let soft = Material::from_micro("soft", 2650.0, 1e4, 4e3, 0.0, 0.0, 0.5, D / 2.0).unwrap();
    let stiff = Material::from_micro("stiff", 2650.0, 1e7, 4e6, 0.0, 0.0, 0.5, D / 2.0).unwrap();
    (soft, stiff)
}

// Hard case: stiffness contrast 1:1000. An 8×8×8 FCC packing of touching, unbonded spheres
// (d = 1 mm), each given at random the soft (Kn 1e4 N/m) or the stiff (Kn 1e7 N/m) material,
// in a box of fixed walls; a platen presses it down at 0.5 m/s for 2000 steps (33 µm, 0.5%
// strain), stops, and the packing settles with viscous damping 0.05 for 20000 steps. The
// standard step is set by the stiff elements; the soft ones' period is √1000 ≈ 32× longer,
// and soft–stiff contacts are as soft as soft–soft ones (springs in series). Deepest overlap
// at the end ~3% of a radius. Checks: the guard never fires, no NaN, every centre inside the walls,
// mechanical + heat − wall work never above its start by more than 1e-3 of the platen's
// work, and the packing ends in equilibrium (unbalanced force ratio < 1e-2) with the load
// carried (platen force > 0).
#[test]
fn stiffness_contrast_1_to_1000_stays_stable() {
    let (soft, stiff) = soft_and_stiff();
    let mut m = Model::new();
    m.add_material(soft).unwrap();
    m.add_material(stiff).unwrap();
    let mut rng = Rng::new(11);
    for p in fcc_111_block(8, 8, 8, D) {
        m.add_particle(p, D / 2.0, (rng.next_u64() % 2) as u32).unwrap();
    }
    let stiff_count = m.particles.material.iter().filter(|&&k| k == 1).count();
    let (lo, hi) = bounds(&m);
    add_box_walls(&mut m, lo, hi, None);
    let mut platen = Wall::plane("platen", hi, -Vec3::z(), (hi.x - lo.x) * (hi.y - lo.y)).unwrap();
    platen.motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -0.5));
    m.add_wall(platen).unwrap();
    m.settings.damping = 0.05;
    let dt = m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    let mut log = Vec::new();
    let t0 = Instant::now();
    run_logged(&mut sim, 2000, 100, &mut log);
    sim.model.wall_mut("platen").unwrap().motion = WallMotion::Fixed;
    run_logged(&mut sim, 20_000, 100, &mut log);
    let secs = t0.elapsed().as_secs_f64();

    let end = log.last().unwrap().energies;
    let work = end.wall_work;
    let growth = max_growth(&log) / work;
    let min_gap = assert_finite_and_inside_walls(&sim.model);
    let overlap = max_overlap_ratio(&sim.model);
    let load = sim.model.walls[sim.model.wall_index("platen").unwrap()].normal_force;
    let stats = sim.contact_stats();
    eprintln!(
        "stiffness contrast 1:1000: {stiff_count} stiff of {} elements, dt {dt:.3e} s, {secs:.1} s; \
         platen work {work:.3e} J, energy account rose by at most {growth:.1e} of it; platen load \
         {load:.3e} N, unbalanced ratio {:.1e}, deepest overlap {overlap:.3} r, closest centre to a \
         wall {min_gap:.2} r",
        sim.model.len(),
        stats.unbalanced_ratio
    );
    assert!(growth < 1e-3, "energy grew by {growth:e} of the work done");
    assert!(load > 0.0, "the platen must be loaded");
    assert!(stats.unbalanced_ratio < 1e-2, "the packing should have settled");
}

/// A settled random packing of grains with radii 0.4–0.5 mm in a `width` square box, built
/// by MatDEM's box builder and deposited as the stdlib's `sediment` does: a fall under 30 g
/// with contact dashpots (restitution 0.3), a balance with local damping 0.7, then a balance
/// under real gravity (unbalanced force ratio < 0.02 each). Linear contacts Kn 1e4 N/m,
/// Ks 4e3 N/m, μp 0.5, rotation on. Returns the simulation (local damping switched off
/// again) and the top of the packing.
fn settled_packing(width: f64, seed: u64) -> (Simulation, f64) {
    let mut mat = Material::from_micro("grain", 2650.0, 1e4, 4e3, 0.0, 0.0, 0.5, D / 2.0).unwrap();
    mat.restitution = 0.3;
    let mut m = Model::new();
    m.add_material(mat).unwrap();
    let spec = BoxSpec {
        container: Container::Cuboid { width, length: width },
        height: width,
        classes: vec![SizeClass { r_min: 0.4e-3, r_max: 0.5e-3, mass_ratio: 1.0 }],
        target_porosity: 0.4,
        seed,
        top_platen: false,
    };
    spec.build_into(&mut m).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81 * 30.0);
    m.settings.rotation = true;
    m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    let ctl = RunControl::default();
    sim.run(30_000, &ctl, &mut |_| {}).unwrap();
    sim.model.settings.local_damping = 0.7;
    let balance = Balance::Tolerance { ratio: 0.02, max_steps: 200_000 };
    sim.balance(balance, &ctl, &mut |_| {}).unwrap();
    sim.model.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    let done = sim.balance(balance, &ctl, &mut |_| {}).unwrap();
    assert!(done.unbalanced_ratio.unwrap() < 0.02, "the packing did not settle");
    sim.model.settings.local_damping = 0.0;
    let p = &sim.model.particles;
    let top = (0..p.len()).map(|i| p.pos[i].z + p.radius[i]).fold(0.0, f64::max);
    (sim, top)
}

// Hard case: a dense packing held for 1e6 steps. A settled random packing of 99 grains
// (`settled_packing`, 4 mm box) under a fixed lid, with contact dashpots removed (restitution
// 1) and no viscous or local damping, so that only friction dissipates; every grain gets a
// random kick of up to 1 mm/s, then 1e6 standard steps (~0.75 s) run with rotation on.
// Checks: the guard never fires, no NaN, every centre inside the walls, mechanical + heat
// never above its start by more than 1e-3 of the kick's kinetic energy (sampled every 1000
// steps), the kinetic energy at the end below that of the kick, and no creep: the mean
// height of the grains changes by less than 1e-4 of a radius over the second half.
// Runs in about 40 s in release (CI's `cargo test --release`); skipped in debug builds.
#[test]
#[cfg_attr(debug_assertions, ignore = "1e6 steps: run with --release")]
fn dense_packing_held_for_1e6_steps_stays_stable() {
    let width = 0.004;
    let t0 = Instant::now();
    let (mut sim, top) = settled_packing(width, 21);
    let prep = t0.elapsed().as_secs_f64();
    let mut mat = sim.model.materials[0].clone();
    mat.restitution = 1.0;
    sim.model.add_material(mat).unwrap();
    let lid = Wall::plane("lid", Vec3::new(0.0, 0.0, top + 0.1 * D), -Vec3::z(), width * width);
    sim.model.add_wall(lid.unwrap()).unwrap();
    let mut rng = Rng::new(9);
    for v in sim.model.particles.vel.iter_mut() {
        *v += Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()).map(|c| 2e-3 * (c - 0.5));
    }
    let dt = sim.model.clock.dt;
    let mut log = Vec::new();
    let t0 = Instant::now();
    run_logged(&mut sim, 500_000, 1000, &mut log);
    let mid = log.last().unwrap().energies;
    run_logged(&mut sim, 500_000, 1000, &mut log);
    let secs = t0.elapsed().as_secs_f64();

    let (first, end) = (log[0].energies, log.last().unwrap().energies);
    let kick = first.kinetic;
    let growth = max_growth(&log) / kick;
    let min_gap = assert_finite_and_inside_walls(&sim.model);
    let weight = sim.model.particles.mass.iter().sum::<f64>() * 9.81;
    let sink = (mid.gravity - end.gravity) / weight / sim.model.mean_radius();
    eprintln!(
        "dense packing held: {} grains, dt {dt:.3e} s, 1e6 steps in {secs:.1} s (+{prep:.1} s to \
         deposit); energy account rose by at most {growth:.1e} of the kick, ended {:+.1e}; kinetic \
         energy at the end {:.1e} of the kick; mean height change over the second half {sink:.1e} r; \
         closest centre to a wall {min_gap:.2} r",
        sim.model.len(),
        (end.total() - first.total()) / kick,
        end.kinetic / kick
    );
    assert!(growth < 1e-3, "energy grew by {growth:e} of the kick");
    assert!(end.kinetic < kick, "the packing must not gain kinetic energy");
    assert!(sink.abs() < 1e-4, "the packing creeps: {sink:e} radii");
}

// Hard case: impact at ten times the usual speed. A grain packing (`settled_packing`, 6 mm
// box, 335 grains) is given the springs a user would pick for impacts at the usual 10 m/s:
// Kn 4e6 N/m, so that δmax = v·√(m*/Kn) ≈ 1% of a grain's radius at 10 m/s (physics.md §2),
// restitution 0.5. A sphere of radius 1.5 mm then hits it at 100 m/s: δmax ≈ 11% of a
// grain's radius for one grain (14% measured, grains being pushed into their neighbours),
// well inside the guard's 50%. 20000 standard steps (~0.75 ms). Checks: the
// guard never fires, no NaN, every centre inside the walls, mechanical + heat never above
// its start by more than 1e-3 of the impact energy, and the deepest overlap stays below the
// guard's limit.
#[test]
fn impact_at_ten_times_usual_speed_stays_stable() {
    let width = 0.006;
    let t0 = Instant::now();
    let (mut sim, top) = settled_packing(width, 5);
    let grains = sim.model.len();
    let mut mat = Material::from_micro("grain", 2650.0, 4e6, 1.6e6, 0.0, 0.0, 0.5, D / 2.0).unwrap();
    mat.restitution = 0.5;
    sim.model.add_material(mat).unwrap();
    let r = 1.5e-3;
    let centre = Vec3::new(width / 2.0, width / 2.0, top + r + 0.05 * D);
    let id = sim.model.add_particle(centre, r, 0).unwrap();
    sim.model.particles.vel[id] = Vec3::new(0.0, 0.0, -100.0);
    let dt = sim.model.set_standard_dt().unwrap();
    let prep = t0.elapsed().as_secs_f64();
    let mut log = Vec::new();
    let mut deepest = 0.0f64;
    let t0 = Instant::now();
    for _ in 0..1000 {
        run_logged(&mut sim, 20, 10, &mut log);
        deepest = deepest.max(max_overlap_ratio(&sim.model));
    }
    let secs = t0.elapsed().as_secs_f64();

    let impact = log[0].energies.kinetic;
    let growth = max_growth(&log) / impact;
    let end = log.last().unwrap().energies;
    let min_gap = assert_finite_and_inside_walls(&sim.model);
    eprintln!(
        "impact at 100 m/s: {grains} grains, dt {dt:.3e} s, {secs:.1} s (+{prep:.1} s to deposit); \
         deepest overlap {deepest:.3} of the smaller radius; energy account rose by at most \
         {growth:.1e}, ended {:+.1e} of the impact energy; heat: dashpots {:.3}, friction {:.3}; \
         impactor leaves at {:.1} m/s; closest centre to a wall {min_gap:.2} r",
        (end.total() - log[0].energies.total()) / impact,
        end.heat_contact_damping / impact,
        end.heat_friction / impact,
        sim.model.particles.vel[id].norm()
    );
    assert!(growth < 1e-3, "energy grew by {growth:e} of the impact energy");
    assert!(deepest < sim.model.settings.max_overlap_ratio);
}

// Hard case: a bonded block crushed until most bonds break. The 8×8×8 bonded FCC block of
// the energy test (E 1 GPa, ν 0.1, Tu 1 MPa, Cu 10 MPa) stands under gravity on the floor of
// a box whose sides are 2 mm away, with viscous damping 0.01; a platen moves down at
// 0.2 m/s, in runs of 500 steps, until more than half of the bonds have broken. Checks: the
// guard never fires, no NaN, every centre inside the walls (the fragments are caught by the
// sides), mechanical + heat − wall work never above its start by more than 1e-3 of the
// platen's work.
#[test]
fn bonded_block_loaded_until_most_bonds_break_stays_stable() {
    let mut m = bonded_block(8, rock(1e6));
    let bonds0 = m.bond_count();
    let (lo, hi) = bounds(&m);
    let margin = Vec3::new(2.0 * D, 2.0 * D, 0.0);
    add_box_walls(&mut m, lo - margin, hi + margin, None);
    let area = (hi.x - lo.x) * (hi.y - lo.y);
    let mut platen = Wall::plane("platen", hi, -Vec3::z(), area).unwrap();
    platen.motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -0.2));
    m.add_wall(platen).unwrap();
    m.settings.damping = 0.01;
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    let dt = m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    let mut log = Vec::new();
    let t0 = Instant::now();
    let mut steps = 0;
    let mut peak_stress = 0.0f64;
    while 2 * sim.model.bond_count() > bonds0 {
        assert!(steps < 100_000, "the block should have failed by now");
        run_logged(&mut sim, 500, 10, &mut log);
        steps += 500;
        peak_stress = peak_stress.max(sim.model.walls[sim.model.wall_index("platen").unwrap()].stress());
    }
    let secs = t0.elapsed().as_secs_f64();

    let end = log.last().unwrap().energies;
    let work = end.wall_work;
    let growth = max_growth(&log) / work;
    let min_gap = assert_finite_and_inside_walls(&sim.model);
    eprintln!(
        "crushed block: {} of {bonds0} bonds broke after {steps} steps (strain {:.4}, peak platen \
         stress {:.2e} Pa), dt {dt:.3e} s, {secs:.1} s; energy account rose by at most {growth:.1e} \
         of the platen work {work:.3e} J; heat: damping {:.3}, breakage {:.3}, friction {:.3}; \
         closest centre to a wall {min_gap:.2} r",
        bonds0 - sim.model.bond_count(),
        0.2 * dt * steps as f64 / (hi.z - lo.z),
        peak_stress,
        end.heat_damping / work,
        end.heat_breakage / work,
        end.heat_friction / work
    );
    assert!(growth < 1e-3, "energy grew by {growth:e} of the work done");
    assert!(end.heat_breakage > 0.0);
}
