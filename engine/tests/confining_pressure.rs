//! The confining pressure (the `confining_pressure` stage, a triaxial cell's membrane) against
//! closed forms and conservation: a chain of two grains pressed against a fixed core comes to
//! rest where the membrane's load on the outer grain, σ·(ρ + r)·Δθ·Δz, meets each contact's
//! spring (the inner grain unloaded by the membrane, so both contacts carry the same force), on
//! both backends; without damping the chain oscillates with kinetic + elastic + σ·V constant; a
//! lattice column under the membrane feels σ on its side and the membrane's volume shrinks as
//! the elastic column's does; the CPU and the GPU agree on the column; a scene without a
//! confinement has no stage; bad settings are refused; a checkpoint carries the confinement.

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::checkpoint::{decode, encode};
use matdem_engine::effects::confining_pressure::ConfineRequest;
use matdem_engine::geometry::lattice::make_column;
use matdem_engine::geometry::LatticeKind;
use matdem_engine::plan::Stage;
use matdem_engine::simulation::EnergySample;
use matdem_engine::{Model, Simulation, StepPlan, Vec3, Wall};
use std::f64::consts::TAU;

const R: f64 = 1e-3;
const KN: f64 = 1e5;
/// Seven sectors (the +x axis, at θ + π = π, in the middle of sector 3), one band 10 mm high: a
/// patch Δθ·Δz per metre of reach.
const SECTORS: u32 = 7;
const HEIGHT: f64 = 10e-3;
const SIGMA: f64 = 2.5e4;

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

fn platens(m: &mut Model, z0: f64, z1: f64) {
    m.add_wall(Wall::plane("bottom", Vec3::new(0.0, 0.0, z0), Vec3::z(), 1e-4).unwrap()).unwrap();
    m.add_wall(Wall::plane("top_platen", Vec3::new(0.0, 0.0, z1), -Vec3::z(), 1e-4).unwrap()).unwrap();
}

fn request(pressure: f64, bands: Option<u32>, sectors: Option<u32>) -> ConfineRequest {
    ConfineRequest { pressure, bottom: "bottom".into(), top: "top_platen".into(), axis: [0.0, 0.0], bands, sectors }
}

/// A fixed core on the axis and two grains in a line from it along +x (touching, no overlap),
/// held to the line (y and z fixed: a compressed frictionless chain free to move sideways
/// buckles, as it should), the platens 5 mm above and below, no gravity; `damping` local.
fn chain(damping: f64) -> Model {
    use matdem_engine::state::particles::dof;
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e7, 0.2)).unwrap();
    for x in [0.0, 2.0 * R, 4.0 * R] {
        m.add_particle(Vec3::new(x, 0.0, 0.0), R, k).unwrap();
    }
    m.particles.fixed = vec![dof::X | dof::Y | dof::Z, dof::Y | dof::Z, dof::Y | dof::Z];
    platens(&mut m, -0.5 * HEIGHT, 0.5 * HEIGHT);
    m.settings.local_damping = damping;
    m.set_standard_dt().unwrap();
    m.confine(request(SIGMA, Some(1), Some(SECTORS))).unwrap();
    m
}

/// The chain's rest: both contacts carry the membrane's load on the outer grain, kn·δ =
/// 3·σ·(ρ + r)·A′ with ρ = 4r − 2δ, A′ = Δθ·Δz (its cell's patch and those of the two empty
/// sectors either side, which it covers; the four beyond have no touched neighbour and push
/// nothing): δ = 5r·3σA′ / (kn + 2·3σA′).
fn chain_rest_overlap() -> f64 {
    let a = 3.0 * SIGMA * TAU / f64::from(SECTORS) * HEIGHT;
    5.0 * R * a / (KN + 2.0 * a)
}

fn check_chain_rest(sim: &mut Simulation, tol: f64) {
    run(sim, 20_000);
    let p = &sim.model.particles;
    let d1 = 2.0 * R - (p.pos[1] - p.pos[0]).norm();
    let d2 = 2.0 * R - (p.pos[2] - p.pos[1]).norm();
    let want = chain_rest_overlap();
    eprintln!("overlaps {d1:.6e}, {d2:.6e} m against {want:.6e} m");
    assert!((d1 - want).abs() < tol * want && (d2 - want).abs() < tol * want, "{d1:e} {d2:e} against {want:e}");
}

// At rest the two contacts' overlaps equal the closed form to 1e-6 (f64; the local damping
// settles the chain within 20,000 steps): the membrane pushes the outer grain alone, with σ times
// its patch and its empty neighbours' at its reach.
#[test]
fn a_chain_against_a_fixed_core_rests_where_the_membrane_load_meets_the_springs() {
    check_chain_rest(&mut Simulation::new(chain(0.7)), 1e-6);
}

// The same rest on the GPU, to 1e-4 (f32 positions: the overlap is 1 % of the radius, whose
// last digit in f32 is 1e-7 of it, so 1e-5 of the overlap, and the rest is reached to ~1e-5).
#[cfg(feature = "gpu")]
#[test]
fn a_chain_against_a_fixed_core_rests_alike_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("confining_pressure_chain") else { return };
    check_chain_rest(&mut Simulation::with_gpu(chain(0.7), ctx), 1e-4);
}

// Without damping the chain oscillates about its rest: kinetic + elastic + σ·V (the membrane's
// potential) stays within 1e-4 of σ·V's swing over 20,000 steps of a quarter of the standard
// step (the leapfrog's error, O((ω·dt)²): 1.0e-3 at the standard step; the kinetic energy
// sampled at the integer step), while σ·V itself swings by the whole motion.
#[test]
fn an_undamped_chain_keeps_kinetic_elastic_and_confining_energy_constant() {
    check_undamped_energy(chain(0.0), "3D");
}

/// Runs undamped chain `m` 20,000 steps at a quarter of its step and holds kinetic + elastic +
/// σ·V within 1e-4 of σ·V's swing.
fn check_undamped_energy(mut m: Model, label: &str) {
    m.set_dt(0.25 * m.clock.dt).unwrap();
    let mut sim = Simulation::new(m);
    let mut log: Vec<EnergySample> = Vec::new();
    sim.run_sampled(20_000, 50, &RunControl::default(), &mut |_| {}, &mut |s| log.push(s)).unwrap();
    let range = |f: &dyn Fn(&EnergySample) -> f64| {
        log.iter().map(f).fold((f64::MAX, f64::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)))
    };
    let (lo, hi) = range(&|s| s.energies.total());
    let (c_lo, c_hi) = range(&|s| s.energies.confining);
    let swing = c_hi - c_lo;
    eprintln!("{label}: total {lo:.9e} .. {hi:.9e} J; σ·V swings {swing:.3e} J");
    assert!(swing > 0.0);
    assert!(hi - lo < 1e-4 * swing, "{label}: the total moves {:e} J, σ·V {swing:e} J", hi - lo);
}

/// The 2D membrane (a biaxial test's): three discs in a row along x in a 2D model of thickness
/// `T2`, the middle one fixed on the axis, the outer two held in z, no gravity. Each outer disc
/// is the one its side's single band touches, pushed inwards with σ·t·Δz whatever its reach.
const T2: f64 = 2e-3;

fn chain_2d(damping: f64) -> Model {
    use matdem_engine::state::particles::dof;
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e7, 0.2)).unwrap();
    for x in [-2.0 * R, 0.0, 2.0 * R] {
        m.add_particle(Vec3::new(x, 0.0, 0.0), R, k).unwrap();
    }
    m.make_planar(Some(T2)).unwrap();
    for (i, f) in [dof::Z, dof::X | dof::Z, dof::Z].into_iter().enumerate() {
        m.particles.fixed[i] |= f;
    }
    platens(&mut m, -0.5 * HEIGHT, 0.5 * HEIGHT);
    m.settings.local_damping = damping;
    m.set_standard_dt().unwrap();
    m.confine(request(SIGMA, Some(1), None)).unwrap();
    m
}

fn check_chain_2d_rest(sim: &mut Simulation, tol: f64) {
    run(sim, 20_000);
    let p = &sim.model.particles;
    // kn·δ = σ·t·H on each side.
    let want = SIGMA * T2 * HEIGHT / KN;
    let d1 = 2.0 * R - (p.pos[1] - p.pos[0]).norm();
    let d2 = 2.0 * R - (p.pos[2] - p.pos[1]).norm();
    eprintln!("2D overlaps {d1:.6e}, {d2:.6e} m against {want:.6e} m");
    assert!((d1 - want).abs() < tol * want && (d2 - want).abs() < tol * want, "{d1:e} {d2:e} against {want:e}");
    let mb = sim.model.membrane().unwrap();
    assert_eq!((mb.cells, mb.touched), (2, 2));
    // Its side is the plate's two sides, 2·t·H, and it holds σ on them.
    assert!((mb.stress - SIGMA).abs() < 1e-9 * SIGMA, "{mb:?}");
}

// The 2D membrane at rest: each contact carries σ·t·H, to 1e-6 on the CPU and 1e-4 on the GPU.
#[test]
fn a_2d_chain_rests_where_the_sides_load_meets_the_springs() {
    check_chain_2d_rest(&mut Simulation::new(chain_2d(0.7)), 1e-6);
}

#[cfg(feature = "gpu")]
#[test]
fn a_2d_chain_rests_alike_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("confining_pressure_chain_2d") else { return };
    check_chain_2d_rest(&mut Simulation::with_gpu(chain_2d(0.7), ctx), 1e-4);
}

// Undamped, the 2D chain keeps kinetic + elastic + σ·V constant, V = Σ (|x − x_axis| + r)·t·Δz
// over its sides: the 2D load is that potential's gradient (as the 3D test, a quarter step).
#[test]
fn an_undamped_2d_chain_keeps_kinetic_elastic_and_confining_energy_constant() {
    check_undamped_energy(chain_2d(0.0), "2D");
}

/// A lattice column (FCC, radius 6 grains, 12 grains high) between platens touching its ends,
/// unbonded and frictionless, no gravity, local damping 0.7; with `varied` the radii are 0.9–1
/// of the lattice's (a golden-ratio sequence), so that no two grains of a cell reach equally far
/// (on the lattice, mirror images tie, and f32 and f64 may break a tie apart), and the side has
/// 41 sectors, so that no sector's edge (at −π + 2πk/41) runs through a row of the lattice's
/// grains (40 put one at −π/2, through the grains on x = 0, which f32 and f64 then place on
/// either side of it).
fn column_of(varied: bool) -> Model {
    let mut m = Model::new();
    let mut mat = material("m", 2650.0, KN, 1e7, 0.2);
    mat.ks = 0.0;
    let k = m.add_material(mat).unwrap();
    let g = make_column(6.0 * 2.0 * R, 12.0 * 2.0 * R, R, LatticeKind::Fcc).unwrap();
    for (i, (x, r)) in g.pos().iter().zip(g.radius()).enumerate() {
        let share = if varied { 0.9 + 0.1 * (i as f64 * 0.618_033_988_75).fract() } else { 1.0 };
        m.add_particle(*x, r * share, k).unwrap();
    }
    let (lo, hi) = g
        .pos()
        .iter()
        .zip(g.radius())
        .fold((f64::MAX, f64::MIN), |(lo, hi), (x, r)| (lo.min(x.z - r), hi.max(x.z + r)));
    platens(&mut m, lo, hi);
    m.settings.local_damping = 0.7;
    m.set_standard_dt().unwrap();
    m.confine(request(SIGMA, None, varied.then_some(41))).unwrap();
    m
}

fn column() -> Model {
    column_of(false)
}

// The column balanced under the membrane: every cell is touched (the default cells, a grain
// diameter each), so the side carries σ to 2 % (the pressure held), the platens standing, and
// the membrane's volume shrinks (the column is squeezed, not blown apart).
#[test]
fn a_lattice_column_under_the_membrane_feels_sigma_on_its_side() {
    let mut sim = Simulation::new(column());
    let before = sim.model.membrane().unwrap();
    run(&mut sim, 4000);
    let after = sim.model.membrane().unwrap();
    eprintln!("{before:?}\n{after:?}");
    assert!(after.touched as f64 >= 0.98 * after.cells as f64, "{} of {} cells touched", after.touched, after.cells);
    assert!((after.stress - SIGMA).abs() < 0.02 * SIGMA, "side stress {} against {SIGMA}", after.stress);
    assert!(after.volume < before.volume, "volume {} → {}", before.volume, after.volume);
    // The platens held the column in: they carry a load.
    assert!(sim.model.walls.iter().all(|w| w.contacts > 0));
}

/// What the column's parity test allows: after 300 steps each grain's displacement within 1e-4
/// of the largest (f32 against f64, the picks alike: no two grains of a cell reach within f32's
/// round-off of each other); balanced after 4,000, the side stress and the membrane's volume
/// relative. The gaps the smaller radii leave close as the membrane squeezes the column: grains
/// change cells, and a pick that two grains all but tie for goes either way, so the
/// trajectories part (1.8e-3 of the largest displacement at 600 steps, 5e-2 at 1,500) and the
/// backends come to rest with a cell more or less touched (lavapipe 483 of 492 against the CPU's
/// 484): the membrane's radius moves by a cell's share and its volume by up to ~5e-3 (lavapipe
/// 3.2e-3, the CPU's rounded twins up to 1.7e-3). The volume is allowed three cells' worth,
/// where a device that rounds otherwise stays within; the stress, which the membrane holds
/// whatever it touches, 5e-3 (lavapipe 2.3e-5).
const COLUMN_PARTING: f64 = 1e-4;
const COLUMN_STRESS: f64 = 5e-3;
const COLUMN_VOLUME: f64 = 1.5e-2;

/// Runs `other` (the column of varied radii on another backend, or its rounded twin) beside the
/// CPU's `cpu`: [parting after 300 steps as a fraction of the largest displacement, then
/// balanced after 4,000: side stress, membrane volume (relative)].
fn column_disagreement(mut cpu: Simulation, mut other: Simulation) -> [f64; 3] {
    run(&mut cpu, 300);
    run(&mut other, 300);
    let (a, b) = (&cpu.model.particles, &other.model.particles);
    let top = (0..a.len()).map(|i| (a.pos[i] - a.origin[i]).norm()).fold(0.0, f64::max);
    // Displacements: positions for runs from one start; a rounded twin's start is none of its run.
    let worst = (0..a.len()).map(|i| ((a.pos[i] - a.origin[i]) - (b.pos[i] - b.origin[i])).norm()).fold(0.0, f64::max);
    eprintln!("after 300 steps: {:.2e} of the largest displacement {top:.3e} m", worst / top);
    assert!(top > 0.0);
    run(&mut cpu, 3700);
    run(&mut other, 3700);
    let (mc, mo) = (cpu.model.membrane().unwrap(), other.model.membrane().unwrap());
    eprintln!("balanced: cpu {mc:?}\n          other {mo:?}");
    [worst / top, (mc.stress - mo.stress).abs() / mc.stress, (mc.volume - mo.volume).abs() / mc.volume]
}

// The column of varied radii on both backends, within `COLUMN_PARTING`, `COLUMN_STRESS` and
// `COLUMN_VOLUME`.
#[cfg(feature = "gpu")]
#[test]
fn a_confined_column_runs_alike_on_the_cpu_and_the_gpu() {
    let Some(ctx) = crate::common::gpu("confining_pressure_column") else { return };
    let d = column_disagreement(Simulation::new(column_of(true)), Simulation::with_gpu(column_of(true), ctx));
    assert!(d[0] < COLUMN_PARTING && d[1] < COLUMN_STRESS && d[2] < COLUMN_VOLUME, "{d:?}");
}

// The column's parity tolerances against rounding alone: the CPU's run beside three rounded twins
// (each position and velocity one rounding away, `rounded_twin`) stays within a third of each
// (measured: parting 2.1e-5, stress 4.5e-5, volume 1.7e-3), so the parity test holds for any
// device's rounding, not only for the one it was measured on.
#[test]
fn the_confined_columns_parity_tolerances_hold_under_f32_rounding() {
    for seed in 1..=3 {
        let twin = crate::common::rounded_twin(column_of(true), seed);
        let d = column_disagreement(Simulation::new(column_of(true)), Simulation::new(twin));
        let third = [COLUMN_PARTING, COLUMN_STRESS, COLUMN_VOLUME].map(|t| t / 3.0);
        assert!(d.iter().zip(third).all(|(x, t)| *x < t), "twin {seed}: {d:?} against {third:?}");
    }
}

#[test]
fn a_scene_without_confinement_has_no_stage_and_with_it_the_plan_says_so() {
    let mut m = chain(0.7);
    let on = StepPlan::build(&m);
    assert!(on.has(Stage::ConfiningPressure));
    assert!(
        on.to_string()
            .contains("confining pressure(σ3 = 2.5000e4 Pa on the grains the membrane touches, 1 bands × 7 sectors)"),
        "{on}"
    );
    m.unconfine();
    let off = StepPlan::build(&m);
    assert!(!off.has(Stage::ConfiningPressure));
    assert!(off.to_string().contains("not simulated:") && off.to_string().contains("confining pressure"));
    assert_eq!(m.confining_potential(), 0.0);
    assert!(m.membrane().is_none());
}

#[test]
fn bad_confinements_are_refused_with_what_to_give() {
    let mut m = chain(0.7);
    m.unconfine();
    // 1e308 Pa made the membrane's forces infinite (the host's robustness test found it).
    let says = "a pressure in Pa above 0 and at most 1e11";
    for (p, says) in [(f64::NAN, says), (-1.0, says), (0.0, "d.unconfine()"), (1e308, says), (1.01e11, says)] {
        let e = m.confine(request(p, None, None)).unwrap_err().to_string();
        assert!(e.contains(says), "{e}");
    }
    let mut swapped = request(1e4, None, None);
    std::mem::swap(&mut swapped.bottom, &mut swapped.top);
    let e = m.confine(swapped).unwrap_err().to_string();
    assert!(e.contains("horizontal plane below the sample"), "{e}");
    let mut unknown = request(1e4, None, None);
    unknown.top = "lid".into();
    let e = m.confine(unknown).unwrap_err().to_string();
    assert!(e.contains("lid") && e.contains("top_platen"), "{e}");
    let e = m.confine(request(1e4, Some(0), None)).unwrap_err().to_string();
    assert!(e.contains("at least 1"), "{e}");
    assert!(m.effects.confining_pressure.confinement.is_none(), "a refused confinement changes nothing");
    // A platen of the confinement cannot be removed while it holds.
    m.confine(request(1e4, None, None)).unwrap();
    let e = m.remove_wall("top_platen").unwrap_err().to_string();
    assert!(e.contains("d.unconfine() first"), "{e}");
}

#[test]
fn a_checkpoint_carries_the_confinement() {
    let mut sim = Simulation::new(chain(0.7));
    run(&mut sim, 100);
    let bytes = encode(&sim.model, &[]);
    let back = decode(&bytes).unwrap().model;
    assert_eq!(back.effects.confining_pressure.confinement, sim.model.effects.confining_pressure.confinement);
    let mut again = Simulation::new(back);
    run(&mut again, 100);
    run(&mut sim, 100);
    assert_eq!(again.model.particles.pos, sim.model.particles.pos, "a loaded model steps as the saved one");
}

// Removing a wall takes its contacts with it: the packing ring of a triaxial sample goes, the
// platens keep their states and masks.
#[test]
fn removing_a_wall_keeps_the_others_contacts() {
    let mut m = chain(0.7);
    m.unconfine();
    m.add_wall(Wall::cylinder("ring", Vec3::zeros(), 6.0 * R, 1e-4).unwrap()).unwrap();
    let mut sim = Simulation::new(m);
    run(&mut sim, 10);
    let n = sim.model.len();
    sim.model.remove_wall("ring").unwrap();
    assert_eq!(sim.model.walls.len(), 2);
    assert_eq!(sim.model.wall_contacts.len(), 2 * n);
    run(&mut sim, 10);
    assert!(sim.model.remove_wall("ring").unwrap_err().to_string().contains("ring"));
}
