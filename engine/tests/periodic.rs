//! Periodic boundaries (the `periodic` stage and the nearest image) against exact answers and
//! conservation: an FCC lattice filling a periodic cell, strained uniformly, carries the stress
//! of the infinite lattice (the closed-form sum over its bonds) to 1e-9; a ball crossing a face
//! keeps its velocity and spin to the bit and its displacement continuous; a collision across a
//! face is the collision inside the cell; a periodic gas with friction keeps its momentum to
//! round-off; the GPU agrees; a checkpoint carries the cell; bad cells are refused.

use crate::common::material;
use matdem_engine::analysis::contact_list::contact_list;
use matdem_engine::analysis::measure::measure;
use matdem_engine::backend::RunControl;
use matdem_engine::checkpoint::{decode, encode};
use matdem_engine::plan::Stage;
use matdem_engine::state::particles::Particles;
use matdem_engine::status::Region;
use matdem_engine::{Model, Simulation, StepPlan, Vec3};
use nalgebra::Matrix3;

const R: f64 = 1e-3;
const KN: f64 = 1e5;

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

type Ctx = std::sync::Arc<matdem_engine::backend::gpu::device::GpuContext>;

/// A scene built straddling the face x = 0 and built mid-cell (at `mid`), both run `steps` on
/// the CPU, or on the GPU of `ctx`: what crosses a face against what does not.
fn across_and_inside(scene: fn(f64) -> Model, mid: f64, steps: u64, ctx: Option<&Ctx>) -> (Simulation, Simulation) {
    run_both(scene(0.0), scene(mid), steps, ctx)
}

/// A scene run `steps` on the CPU and on the GPU of `ctx`.
fn cpu_and_gpu(scene: fn() -> Model, steps: u64, ctx: Ctx) -> (Simulation, Simulation) {
    let (mut cpu, mut gpu) = (Simulation::new(scene()), Simulation::with_gpu(scene(), ctx));
    run(&mut cpu, steps);
    run(&mut gpu, steps);
    (cpu, gpu)
}

/// How far two runs of one scene went apart (m): the largest move of `a`'s elements, and the
/// largest differences of their positions and of their displacements.
fn divergence(a: &Particles, b: &Particles) -> (f64, f64, f64) {
    let most = |f: &dyn Fn(usize) -> f64| (0..a.len()).map(f).fold(0.0, f64::max);
    (
        most(&|i| (a.pos[i] - a.origin[i]).norm()),
        most(&|i| (a.pos[i] - b.pos[i]).norm()),
        most(&|i| ((a.pos[i] - a.origin[i]) - (b.pos[i] - b.origin[i])).norm()),
    )
}

/// The elements that crossed a z face since `start` (their displacement origins moved in z).
fn crossed_z(p: &Particles, start: &Model) -> Vec<usize> {
    (0..p.len()).filter(|&i| p.origin[i].z != start.particles.origin[i].z).collect()
}

/// Two scenes, each run `steps` on the CPU, or on the GPU of `ctx`.
fn run_both(across: Model, inside: Model, steps: u64, ctx: Option<&Ctx>) -> (Simulation, Simulation) {
    let make = |m: Model| match ctx {
        Some(ctx) => Simulation::with_gpu(m, ctx.clone()),
        None => Simulation::new(m),
    };
    let (mut across, mut inside) = (make(across), make(inside));
    run(&mut across, steps);
    run(&mut inside, steps);
    (across, inside)
}

fn cube(a: [f64; 2]) -> [Option<[f64; 2]>; 3] {
    [Some(a), Some(a), Some(a)]
}

/// The 12 nearest neighbours of an FCC site, for cubic cell a.
fn fcc_neighbours(a: f64) -> Vec<Vec3> {
    let mut out = Vec::new();
    for (p, q) in [(0, 1), (0, 2), (1, 2)] {
        for s in [-1.0, 1.0] {
            for t in [-1.0, 1.0] {
                let mut v = Vec3::zeros();
                v[p] = s * a / 2.0;
                v[q] = t * a / 2.0;
                out.push(v);
            }
        }
    }
    out
}

/// n³ cubic cells of FCC spheres of radius R touching (a = 2√2·R), compressed along x by `eps`.
fn strained_fcc(n: usize, eps: f64) -> (Model, f64) {
    let a = 2.0 * 2f64.sqrt() * R;
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e7, 0.2)).unwrap();
    let basis = [[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]];
    let squeeze = Vec3::new(1.0 - eps, 1.0, 1.0);
    for (x, y, z) in (0..n).flat_map(|x| (0..n).flat_map(move |y| (0..n).map(move |z| (x, y, z)))) {
        for b in basis {
            let p = Vec3::new(x as f64 + b[0] + 0.25, y as f64 + b[1] + 0.25, z as f64 + b[2] + 0.25) * a;
            m.add_particle(p.component_mul(&squeeze), R, k).unwrap();
        }
    }
    let span = n as f64 * a;
    m.periodic([Some([0.0, span * (1.0 - eps)]), Some([0.0, span]), Some([0.0, span])]).unwrap();
    (m, a)
}

/// σ = −(1/V)·Σ f ⊗ l over the cell's contacts (compression positive).
fn cell_stress(m: &Model, volume: f64) -> Matrix3<f64> {
    let list = contact_list(m, &StepPlan::build(m));
    let mut s = Matrix3::zeros();
    for c in list.rows.iter().filter(|c| c.j().is_some()) {
        s -= c.force * c.branch.transpose();
    }
    s / volume
}

#[test]
fn a_strained_periodic_fcc_lattice_carries_the_infinite_lattices_stress() {
    let (n, eps) = (4, 1e-3);
    let (m, a) = strained_fcc(n, eps);
    let volume = (n as f64 * a).powi(3) * (1.0 - eps);
    let got = cell_stress(&m, volume);
    // The infinite lattice: per site six bonds (each of the 12 neighbours shared), a site per
    // a³/4 of volume; a bond of branch l presses with KN·(2R − |l|) along it.
    let squeeze = Vec3::new(1.0 - eps, 1.0, 1.0);
    let mut want = Matrix3::zeros();
    for l in fcc_neighbours(a).iter().map(|v| v.component_mul(&squeeze)) {
        let f = KN * (2.0 * R - l.norm());
        want += 0.5 * f * (l * l.transpose()) / l.norm();
    }
    want *= 4.0 / (a * a * a * (1.0 - eps));
    eprintln!("cell {got}\ninfinite {want}");
    assert!(want[(0, 0)] > 0.0);
    assert!((got - want).norm() < 1e-9 * want.norm(), "cell {got} against {want}");
    // d.measure over the whole cell: every branch counted whole through the faces, and every
    // sphere's volume (those cut by a face come in through the other).
    let span = n as f64 * a;
    let region = Region::Box { lo: Vec3::zeros(), hi: Vec3::new(span * (1.0 - eps), span, span) };
    let got = measure(&m, &contact_list(&m, &StepPlan::build(&m)), &region).unwrap();
    let solid = m.len() as f64 * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    eprintln!("measured {}, porosity {}", got.stress, got.porosity);
    assert!((got.stress - want).norm() < 1e-9 * want.norm(), "measured {} against {want}", got.stress);
    assert!((got.porosity - (1.0 - solid / volume)).abs() < 1e-12, "porosity {}", got.porosity);
    // Without the images the boundary's bonds are missing: the same lattice, not periodic.
    let mut open = m.clone();
    open.unperiodic();
    matdem_engine::neighbours::rebuild(&mut open);
    let short = cell_stress(&open, volume);
    assert!((short - want).norm() > 0.1 * want.norm(), "the open block misses its boundary bonds");
}

/// A 2D model's porosity by area over its periodic cell counts the discs cut by a face whole
/// (their parts come in through the other), as its 3D twin counts spheres.
#[test]
fn porosity_over_a_periodic_cell_counts_the_discs_cut_by_its_faces_whole() {
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e7, 0.2)).unwrap();
    for (x, z) in [(0.2, 5.0), (5.0, 9.7), (5.0, 5.0), (9.9, 0.1)] {
        m.add_particle(Vec3::new(x * R, 0.0, z * R), R, k).unwrap();
    }
    m.make_planar(Some(2.0 * R)).unwrap();
    m.periodic([Some([0.0, 10.0 * R]), None, Some([0.0, 10.0 * R])]).unwrap();
    let region = Region::Box { lo: Vec3::new(0.0, -R, 0.0), hi: Vec3::new(10.0 * R, R, 10.0 * R) };
    let got = matdem_engine::status::porosity(&m, &region);
    let want = 1.0 - 4.0 * std::f64::consts::PI * R * R / (100.0 * R * R);
    assert!((got - want).abs() < 1e-12, "porosity {got} against {want}");
}

fn ball(v: Vec3, w: Vec3) -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e7, 0.2)).unwrap();
    m.add_particle(Vec3::new(9.5, 5.0, 5.0) * R, R, k).unwrap();
    m.particles.vel[0] = v;
    m.settings.rotation = true;
    m.particles.enable_rotation();
    m.particles.rotation.as_mut().unwrap().ang_vel[0] = w;
    m.periodic([Some([0.0, 10.0 * R]), None, None]).unwrap();
    m.set_dt(1e-5).unwrap();
    m
}

/// `f32`: the device holds velocities in f32, so "to the bit" is to the f32 it was given;
/// positions to 1e-4 of a radius there (an f32 ulp at 1 cm is 1e-9 m), 1e-6 on the CPU.
fn check_crossing(sim: &mut Simulation, f32: bool) {
    let round = |v: Vec3| if f32 { v.map(|x| f64::from(x as f32)) } else { v };
    let (v, w) = (round(sim.model.particles.vel[0]), round(sim.model.particles.rotation.as_ref().unwrap().ang_vel[0]));
    let tol = if f32 { 1e-4 * R } else { 1e-6 * R };
    let (x0, o0) = (sim.model.particles.pos[0], sim.model.particles.origin[0]);
    run(sim, 300);
    let p = &sim.model.particles;
    let r = p.rotation.as_ref().unwrap();
    assert_eq!((p.vel[0], r.ang_vel[0]), (v, w), "velocity and spin to the bit");
    let travelled = v * 300.0 * 1e-5;
    assert!(p.pos[0].x < 5.0 * R, "crossed and came back in: x = {}", p.pos[0].x);
    assert!((p.pos[0] - (x0 + travelled - Vec3::x() * 10.0 * R)).norm() < tol, "{:?}", p.pos[0]);
    assert!(((p.pos[0] - p.origin[0]) - (x0 - o0 + travelled)).norm() < tol, "the displacement is continuous");
}

#[test]
fn a_ball_crossing_a_periodic_face_keeps_its_velocity_and_spin_bitwise() {
    let m = ball(Vec3::new(1.0, 0.2, 0.0), Vec3::new(1.0, 2.0, 3.0));
    let plan = StepPlan::build(&m);
    assert!(plan.has(Stage::Periodic) && plan.to_string().contains("periodic(x ∈ [0.0000e0, 1.0000e-2))"), "{plan}");
    check_crossing(&mut Simulation::new(m), false);
}

#[test]
fn a_ball_crossing_a_periodic_face_on_the_gpu_keeps_its_velocity_and_spin_bitwise() {
    let Some(ctx) = crate::common::gpu("periodic_crossing") else { return };
    check_crossing(&mut Simulation::with_gpu(ball(Vec3::new(1.0, 0.2, 0.0), Vec3::new(1.0, 2.0, 3.0)), ctx), true);
}

/// Two balls meeting head-on at `x` (their contact point), in a periodic cell [0, 10R) in x;
/// the gap closes 103.7 steps after the start, so a position's last bit cannot move the
/// contact's first step (which would change the discrete restitution by a few per cent).
fn head_on(x: f64) -> Model {
    let mut m = Model::new();
    let mut mat = material("m", 2650.0, KN, 1e7, 0.2);
    mat.restitution = 0.6;
    let k = m.add_material(mat).unwrap();
    for (side, v) in [(-1.0, 0.5), (1.0, -0.5)] {
        let c = Vec3::new(x + side * 1.051_85 * R, 5.0 * R, 5.0 * R);
        let i = m.add_particle(c, R, k).unwrap();
        m.particles.vel[i] = Vec3::new(v, 0.01, 0.0);
    }
    m.periodic([Some([0.0, 10.0 * R]), None, None]).unwrap();
    m.set_dt(1e-6).unwrap();
    m
}

#[test]
fn a_collision_across_a_face_is_the_collision_inside_the_cell() {
    let (across, inside) = across_and_inside(head_on, 5.0 * R, 3000, None);
    let (a, b) = (&across.model.particles, &inside.model.particles);
    eprintln!("across {:?} {:?}; inside {:?} {:?}", a.vel[0], a.vel[1], b.vel[0], b.vel[1]);
    assert!(b.vel[0].x < -0.1, "the inside pair bounced");
    for i in 0..2 {
        assert!((a.vel[i] - b.vel[i]).norm() < 1e-9, "{i}: {:?} against {:?}", a.vel[i], b.vel[i]);
    }
}

/// The gases' frictional material (μ 0.5, restitution 0.7).
fn gas_material() -> matdem_engine::Material {
    let mut mat = material("m", 2650.0, KN, 1e7, 0.2);
    (mat.ks, mat.mu_p, mat.restitution) = (4e4, 0.5, 0.7);
    mat
}

/// Uniform numbers in [0, 1) from `seed` (a linear congruential generator: the same gas on
/// every machine).
fn uniform_numbers(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A gas of 216 frictional balls in a fully periodic cube, random velocities of zero mean, no
/// gravity, no damping but the contacts'.
fn gas() -> Model {
    let mut m = Model::new();
    let k = m.add_material(gas_material()).unwrap();
    let mut uniform = uniform_numbers(12345u64);
    for (x, y, z) in (0..6).flat_map(|x| (0..6).flat_map(move |y| (0..6).map(move |z| (x, y, z)))) {
        // The last layer 0.05 R inside the upper faces: it crosses within the first steps.
        let c = Vec3::new(x as f64, y as f64, z as f64) * 2.4 * R + Vec3::repeat(2.35 * R);
        let i = m.add_particle(c, R * (0.9 + 0.1 * uniform()), k).unwrap();
        m.particles.vel[i] = Vec3::new(uniform() - 0.5, uniform() - 0.5, uniform() - 0.5);
    }
    let mean = m.particles.vel.iter().sum::<Vec3>() / m.len() as f64;
    m.particles.vel.iter_mut().for_each(|v| *v -= mean);
    m.settings.rotation = true;
    m.periodic(cube([0.0, 6.0 * 2.4 * R])).unwrap();
    m.set_standard_dt().unwrap();
    m
}

fn momentum(m: &Model) -> (Vec3, f64) {
    let p = &m.particles;
    let total = (0..p.len()).map(|i| p.vel[i] * p.mass[i]).sum::<Vec3>();
    let scale = (0..p.len()).map(|i| p.vel[i].norm() * p.mass[i]).sum::<f64>();
    (total, scale)
}

#[test]
fn a_periodic_gas_keeps_its_momentum_to_round_off() {
    let mut sim = Simulation::new(gas());
    let (p0, scale) = momentum(&sim.model);
    let mut touched = 0;
    for _ in 0..40 {
        run(&mut sim, 100);
        touched = touched.max(sim.contact_stats().contacts);
    }
    let (p1, _) = momentum(&sim.model);
    let crossed =
        sim.model.particles.pos.iter().zip(&sim.model.particles.origin).filter(|(x, o)| (*x - *o).norm() > 0.0);
    eprintln!("momentum {p0:?} -> {p1:?} (scale {scale:e}); {} moved", crossed.count());
    assert!((p1 - p0).norm() < 1e-12 * scale, "momentum {p0:?} -> {p1:?}");
    assert!(touched > 0, "the gas collides");
}

#[test]
fn a_periodic_gas_runs_alike_on_the_cpu_and_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_gas") else { return };
    // A horizon the collisions' amplification of f32's round-off allows (at 1500 steps the
    // positions differ by 4e-3 of the largest move: the gas is chaotic).
    let (cpu, gpu) = cpu_and_gpu(gas, 300, ctx);
    let (a, b) = (&cpu.model.particles, &gpu.model.particles);
    let (moved, worst, disp) = divergence(a, b);
    let start = gas();
    let crossed = (0..a.len()).filter(|&i| a.origin[i] != start.particles.origin[i]).count();
    let crossed_gpu = (0..a.len()).filter(|&i| b.origin[i] != start.particles.origin[i]).count();
    assert!(crossed > 0 && crossed == crossed_gpu, "{crossed} crossed a face on the CPU, {crossed_gpu} on the GPU");
    eprintln!("after 300 steps ({crossed} crossed a face): positions {worst:.3e} m, displacements {disp:.3e} m, of {moved:.3e} m moved");
    // f32 positions near 1.4 cm (an ulp of 9e-10 m) resolve the impacts' overlaps of ~1e-5 m
    // to ~1e-4: measured 3.7e-4 of the largest move on lavapipe.
    assert!(worst < 1e-3 * moved && disp < 1e-3 * moved, "{worst:e} / {disp:e} against {moved:e}");
    let (pa, scale) = momentum(&cpu.model);
    let (pb, _) = momentum(&gpu.model);
    assert!((pa - pb).norm() < 1e-5 * scale, "momentum {pa:?} against {pb:?}");
}

#[test]
fn a_checkpoint_carries_the_periodic_cell() {
    let mut sim = Simulation::new(gas());
    run(&mut sim, 300);
    let mut back = Simulation::new(decode(&encode(&sim.model, b"")).unwrap().model);
    assert_eq!(back.model.effects.periodic.cell, sim.model.effects.periodic.cell);
    run(&mut sim, 300);
    run(&mut back, 300);
    assert_eq!(back.model.particles.pos, sim.model.particles.pos);
}

#[test]
fn bad_periodic_cells_are_refused_with_what_to_do() {
    let mut m = gas();
    let e = m.periodic([Some([0.0, 3.0 * R]), None, None]).unwrap_err().to_string();
    assert!(e.contains("at least 3·(2·r_max + skin)") && e.contains("widen the cell"), "{e}");
    let e = m.periodic([Some([1.0, 0.0]), None, None]).unwrap_err().to_string();
    assert!(e.contains("the first below the second"), "{e}");
    assert!(m.periodic([None, None, None]).is_err());
    m.settings.pores.enabled = true;
    let e = Simulation::new(m).run(1, &RunControl::default(), &mut |_| {}).unwrap_err().to_string();
    assert!(e.contains("do not yet work with pore flow"), "{e}");
}

/// The rows the device builds (rows.wgsl and cell_list.wgsl, behind PERIODIC) are the host's:
/// the strained FCC cell, whose boundary pairs meet through the images.
#[test]
fn rows_built_on_the_gpu_for_a_periodic_cell_are_the_hosts() {
    use matdem_engine::backend::gpu::GpuBackend;
    let Some(ctx) = crate::common::gpu("periodic_device_rows") else { return };
    let (m, _) = strained_fcc(4, 1e-3);
    let mut gpu = m.clone();
    let mut backend = GpuBackend::prepare(ctx, &gpu).unwrap();
    backend.build_rows_once(&mut gpu).unwrap().expect("the rows fit their slots");
    let (a, b) = (&gpu.contacts, &m.contacts);
    for i in 0..m.len() {
        let (mut ra, mut rb) = (a.other[a.row(i)].to_vec(), b.other[b.row(i)].to_vec());
        ra.sort_unstable();
        rb.sort_unstable();
        assert_eq!(ra, rb, "row {i}");
        assert_eq!(ra.len(), 12, "row {i}: an FCC site's twelve neighbours, through the faces too");
    }
}

/// Two bonded balls flying apart at 2 m/s each: across a face the bond stretches and
/// breaks at the step it breaks inside the cell, and pulls as hard (its state is the pair's,
/// whichever image the pair meets through).
fn bonded_pair(x: f64) -> Model {
    let mut m = Model::new();
    let mut mat = material("m", 2650.0, KN, 1e7, 0.2);
    (mat.ks, mat.xb, mat.fs0) = (4e4, 2e-5, 1.0);
    let k = m.add_material(mat).unwrap();
    for (side, v) in [(-1.0, -2.0), (1.0, 2.0)] {
        let i = m.add_particle(Vec3::new(x + side * R, 5.0 * R, 5.0 * R), R, k).unwrap();
        m.particles.vel[i] = Vec3::new(v, 0.0, 0.0);
    }
    m.periodic([Some([0.0, 10.0 * R]), None, None]).unwrap();
    assert_eq!(m.connect(None, 1e-9).unwrap(), 1);
    m.set_dt(1e-7).unwrap();
    m
}

#[test]
fn a_bond_across_a_face_stretches_and_breaks_as_inside_the_cell() {
    let (mut across, mut inside) = (Simulation::new(bonded_pair(0.0)), Simulation::new(bonded_pair(5.0 * R)));
    for _ in 0..40 {
        run(&mut across, 10);
        run(&mut inside, 10);
        let (a, b) = (&across.model.particles, &inside.model.particles);
        assert!((a.vel[0] - b.vel[0]).norm() < 1e-9, "{:?} against {:?}", a.vel[0], b.vel[0]);
        assert!((a.force[1] - b.force[1]).norm() < 1e-9 * KN * R, "{:?} against {:?}", a.force[1], b.force[1]);
    }
    let (a, b) = (&across.model.breakages, &inside.model.breakages);
    eprintln!("across {a:?}\ninside {b:?}");
    assert_eq!(a.len(), 1, "the bond broke");
    assert_eq!(a[0].step, b[0].step, "at the same step");
}

/// The gas sheared by Lees–Edwards images (x along z at γ̇ = 20/s), started in the streaming
/// profile with no net momentum. A crossing of a z face changes v_x by ∓γ̇·L_z and z by ∓L_z
/// together, and the pair forces (their relative velocities through the sliding images
/// included) are equal and opposite, so the peculiar momentum Σ m·(v − γ̇·z·e_x) stays as it was
/// to round-off while the elements stream through the faces.
fn sheared_gas(rate: f64) -> Model {
    let mut m = gas();
    let p = &mut m.particles;
    let mass: f64 = p.mass.iter().sum();
    let mean = (0..p.len()).map(|i| p.vel[i] * p.mass[i]).sum::<Vec3>() / mass;
    let z_mid = 0.5 * 6.0 * 2.4 * R;
    for i in 0..p.len() {
        p.vel[i] -= mean;
        p.vel[i].x += rate * (p.pos[i].z - z_mid);
    }
    m.lees_edwards(rate).unwrap();
    m
}

fn peculiar_momentum(m: &Model, rate: f64) -> Vec3 {
    let p = &m.particles;
    (0..p.len()).map(|i| (p.vel[i] - Vec3::x() * rate * p.pos[i].z) * p.mass[i]).sum()
}

#[test]
fn lees_edwards_shear_keeps_the_peculiar_momentum_to_round_off() {
    let rate = 20.0;
    let mut sim = Simulation::new(sheared_gas(rate));
    assert!(StepPlan::build(&sim.model).to_string().contains("Lees–Edwards shear γ̇ = 2.0000e1 1/s"));
    let (p0, (_, scale)) = (peculiar_momentum(&sim.model, rate), momentum(&sim.model));
    let start = sim.model.particles.origin.clone();
    let mut touched = 0;
    for _ in 0..40 {
        run(&mut sim, 100);
        touched = touched.max(sim.contact_stats().contacts);
    }
    let m = &sim.model;
    let p1 = peculiar_momentum(m, rate);
    let crossed_z = (0..m.len()).filter(|&i| m.particles.origin[i].z != start[i].z).count();
    let offset = m.effects.periodic.cell.unwrap().shear.unwrap().offset;
    eprintln!(
        "peculiar momentum {p0:?} -> {p1:?} (scale {scale:e}); {crossed_z} crossed a z face; offset {offset:e} m"
    );
    assert!(crossed_z > 0 && touched > 0, "elements stream through the z faces and collide");
    assert!((p1 - p0).norm() < 1e-12 * scale, "peculiar momentum {p0:?} -> {p1:?}");
    let span = 6.0 * 2.4 * R;
    let slid = rate * span * 4000.0 * m.clock.dt;
    assert!((offset - slid.rem_euclid(span)).abs() < 1e-12 * span, "offset {offset} against γ̇·L_z·t = {slid}");
}

/// A ball leaving through the top of a sheared cell comes in at the bottom shifted back along x
/// by the images' offset and slower by γ̇·L_z: it continues as the image it was.
fn sheared_ball() -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e7, 0.2)).unwrap();
    m.add_particle(Vec3::new(5.0, 5.0, 9.455) * R, R, k).unwrap();
    m.particles.vel[0] = Vec3::new(0.3, 0.0, 1.0);
    m.periodic([Some([0.0, 10.0 * R]), None, Some([0.0, 10.0 * R])]).unwrap();
    m.set_dt(1e-5).unwrap();
    m.lees_edwards(SHEARED_BALL_RATE).unwrap();
    m
}

const SHEARED_BALL_RATE: f64 = 50.0;

/// After 100 steps (1 mm up, through the top in step 55): v_x less the slide, z 0.455 mm above
/// the bottom, x moved by the offset, the displacement the image's path (`tol`: m/s and m).
fn check_sheared_ball(sim: &Simulation, tol: f64) {
    let m = &sim.model;
    let (p, v) = (m.particles.pos[0], m.particles.vel[0]);
    let slide = SHEARED_BALL_RATE * 10.0 * R;
    assert_eq!(v.z, 1.0);
    assert!((v.x - (0.3 - slide)).abs() < tol, "v_x {} against {}", v.x, 0.3 - slide);
    // z: 9.455R + 1 mm − 10R; x: 5R + 0.3 mm, less the offset at the crossing, then at v_x − slide.
    assert!((p.z - 0.455e-3).abs() < tol, "z {}", p.z);
    assert!(
        p.x > 0.0 && p.x < 10.0 * R && (p.x - 5.0 * R - 0.3e-3).abs() > 1e-5,
        "moved along x by the offset: {}",
        p.x
    );
    // The displacement is continuous: 1 mm up, and along x 55 steps at 0.3 m/s and 45 at
    // 0.3 m/s less the slide.
    let u = p - m.particles.origin[0];
    let expected = Vec3::new((0.3 * 55.0 + (0.3 - slide) * 45.0) * 1e-5, 0.0, 1e-3);
    assert!((u - expected).norm() < 10.0 * tol, "displacement {u:?} against {expected:?}");
}

/// How far the images have slid (m).
fn offset(sim: &Simulation) -> f64 {
    sim.model.effects.periodic.cell.and_then(|c| c.shear).map_or(f64::NAN, |s| s.offset)
}

#[test]
fn a_ball_leaving_a_sheared_cell_continues_as_its_image() {
    let mut sim = Simulation::new(sheared_ball());
    run(&mut sim, 100);
    check_sheared_ball(&sim, 1e-12);
}

#[test]
fn a_ball_leaving_a_sheared_cell_on_the_gpu_continues_as_its_image() {
    let Some(ctx) = crate::common::gpu("periodic_lees_edwards_ball") else { return };
    let (cpu, gpu) = cpu_and_gpu(sheared_ball, 100, ctx);
    // f32 positions of ~1e-2 m (an ulp of 1e-9 m) and velocities of ~1 m/s.
    check_sheared_ball(&gpu, 1e-6);
    // Each step's move of 1e-5 m rounds in an f32 displacement of up to 1e-2 m (after the
    // wrap's −L_z): ~5e-10 m a step, 100 steps.
    let (a, b) = (cpu.model.particles.pos[0], gpu.model.particles.pos[0]);
    assert!((a - b).norm() < 1e-7, "CPU {a:?} against GPU {b:?}");
    assert_eq!(offset(&gpu), offset(&cpu), "the offset advances alike");
}

/// Local and viscous damping act on whole velocities: under a sliding cell they would drag the
/// shear's stream towards rest, so a run is refused with what to do; a stopped slide may damp.
#[test]
fn lees_edwards_shear_refuses_damping_that_would_brake_the_stream() {
    for (local, viscous, what) in [(0.2, 0.0, "local damping"), (0.0, 0.1, "viscous damping")] {
        let mut m = sheared_gas(20.0);
        (m.settings.local_damping, m.settings.damping) = (local, viscous);
        let e = Simulation::new(m).run(1, &RunControl::default(), &mut |_| {}).unwrap_err().to_string();
        assert!(e.contains(what) && e.contains("set it to 0 while the cell slides"), "{e}");
    }
    let mut m = sheared_gas(20.0);
    m.settings.local_damping = 0.2;
    m.lees_edwards(0.0).unwrap();
    run(&mut Simulation::new(m), 1);
}

#[test]
fn lees_edwards_shear_is_refused_without_x_and_z_periodic() {
    let mut m = gas();
    m.unperiodic();
    assert!(m.lees_edwards(1.0).unwrap_err().to_string().contains("make x and z periodic first"));
    m.periodic([Some([0.0, 6.0 * 2.4 * R]), None, None]).unwrap();
    assert!(m.lees_edwards(1.0).unwrap_err().to_string().contains("both x and z must be periodic"));
}

/// The sheared gas on the GPU against the CPU over the horizon f32 allows a chaotic gas (as
/// `a_periodic_gas_runs_alike_on_the_cpu_and_the_gpu`), then alone: the same elements cross the
/// z faces, the offset advances alike, and the peculiar momentum holds to f32 round-off.
#[test]
fn lees_edwards_shear_on_the_gpu_runs_as_on_the_cpu() {
    let Some(ctx) = crate::common::gpu("periodic_lees_edwards_gpu") else { return };
    let rate = 20.0;
    let (cpu, mut gpu) = cpu_and_gpu(|| sheared_gas(20.0), 300, ctx);
    let start = sheared_gas(rate);
    let (a, b) = (&cpu.model.particles, &gpu.model.particles);
    let (moved, worst, disp) = divergence(a, b);
    let (ca, cb) = (crossed_z(a, &start), crossed_z(b, &start));
    eprintln!(
        "after 300 steps ({} crossed a z face): positions {worst:.3e} m, displacements {disp:.3e} m, of {moved:.3e} m moved",
        ca.len()
    );
    assert!(!ca.is_empty() && ca == cb, "{ca:?} crossed a z face on the CPU, {cb:?} on the GPU");
    assert_eq!(offset(&gpu), offset(&cpu), "the offset advances alike");
    // As the unsheared gas: f32 positions near 1.4 cm resolve the impacts' overlaps to ~1e-4.
    assert!(worst < 1e-3 * moved && disp < 1e-3 * moved, "{worst:e} / {disp:e} against {moved:e}");
    let (p0, (_, scale)) = (peculiar_momentum(&start, rate), momentum(&start));
    let mut touched = 0;
    for _ in 0..37 {
        run(&mut gpu, 100);
        touched = touched.max(gpu.contact_stats().contacts);
    }
    let p1 = peculiar_momentum(&gpu.model, rate);
    eprintln!("GPU peculiar momentum {p0:?} -> {p1:?} (scale {scale:e}), {touched} contacts at most");
    assert!(touched > 0, "the gas collides");
    // f32 velocities: each ball's momentum rounds at ~6e-8 of its own (measured on lavapipe:
    // 1.8e-8 of the scale after 4000 steps).
    assert!((p1 - p0).norm() < 1e-6 * scale, "peculiar momentum {p0:?} -> {p1:?}");
}

/// A 2D gas of 100 frictional discs in the x–z plane, periodic in x and z and sheared at
/// γ̇ = 20/s from the streaming profile: the planar pair pass (CPU) and `in_plane` (GPU)
/// through the sliding images.
fn sheared_disc_gas() -> Model {
    let mut m = Model::new();
    let k = m.add_material(gas_material()).unwrap();
    let mut uniform = uniform_numbers(777u64);
    // Rows 2.1 R apart (gaps of 0.1 R and more), the top row 0.05 R below the top face.
    let span = 10.0 * 2.1 * R;
    for (x, z) in (0..10).flat_map(|x| (0..10).map(move |z| (x, z))) {
        let c = Vec3::new(x as f64 * 2.1 * R + 1.05 * R, 0.0, z as f64 * 2.1 * R + 2.05 * R);
        let i = m.add_particle(c, R * (0.9 + 0.1 * uniform()), k).unwrap();
        m.particles.vel[i] = Vec3::new(uniform() - 0.5, 0.0, uniform() - 0.5);
    }
    m.make_planar(None).unwrap();
    m.settings.rotation = true;
    m.periodic([Some([0.0, span]), None, Some([0.0, span])]).unwrap();
    m.set_standard_dt().unwrap();
    let rate = 20.0;
    for i in 0..m.len() {
        m.particles.vel[i].x += rate * (m.particles.pos[i].z - 0.5 * span);
    }
    m.lees_edwards(rate).unwrap();
    m
}

#[test]
fn a_sheared_2d_gas_runs_alike_on_the_cpu_and_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_sheared_2d") else { return };
    let (mut cpu, mut gpu) = (Simulation::new(sheared_disc_gas()), Simulation::with_gpu(sheared_disc_gas(), ctx));
    let start = sheared_disc_gas();
    let mut touched = 0;
    for _ in 0..3 {
        run(&mut cpu, 100);
        run(&mut gpu, 100);
        touched = touched.max(cpu.contact_stats().contacts);
    }
    assert!(touched > 0, "the discs collide");
    let (a, b) = (&cpu.model.particles, &gpu.model.particles);
    let (moved, worst, _) = divergence(a, b);
    let (ca, cb) = (crossed_z(a, &start), crossed_z(b, &start));
    eprintln!("2D, 300 steps ({} crossed a z face): positions {worst:.3e} m of {moved:.3e} m moved", ca.len());
    assert!(!ca.is_empty() && ca == cb, "{ca:?} crossed a z face on the CPU, {cb:?} on the GPU");
    assert!(b.pos.iter().all(|x| x.y == 0.0), "the discs stay in the plane");
    assert!(worst < 1e-3 * moved, "{worst:e} against {moved:e}");
    assert_eq!(offset(&gpu), offset(&cpu), "the offset advances alike");
}

/// Two frictional balls pressed together across the z face of a cell sheared at γ̇ (0.5 m/s
/// of slide), both at rest: the upper one's image slides past the lower one, so friction
/// drags it along x. `across`: ball B near the bottom meets A near the top through its image
/// one cell up; else the same pair inside an unsheared cell, B' where that image is, moving
/// at the slide. Either way the same contact: A's velocity agrees.
fn sliding_pair(across: bool) -> Model {
    let mut m = Model::new();
    let mut mat = material("m", 2650.0, KN, 1e7, 0.2);
    (mat.ks, mat.mu_p) = (4e4, 0.5);
    let k = m.add_material(mat).unwrap();
    let (za, zb) = if across { (9.0, 0.95) } else { (4.0, 5.95) };
    m.add_particle(Vec3::new(5.0, 5.0, za) * R, R, k).unwrap();
    let b = m.add_particle(Vec3::new(5.0, 5.0, zb) * R, R, k).unwrap();
    m.periodic([Some([0.0, 10.0 * R]), None, Some([0.0, 10.0 * R])]).unwrap();
    if across {
        m.lees_edwards(SHEARED_BALL_RATE).unwrap();
    } else {
        m.particles.vel[b].x = SHEARED_BALL_RATE * 10.0 * R;
    }
    m.set_dt(1e-7).unwrap();
    m
}

fn check_sliding_pair(across: &Simulation, inside: &Simulation, tol: f64) {
    let (a, b) = (across.model.particles.vel[0], inside.model.particles.vel[0]);
    eprintln!("A across {a:?}, inside {b:?}");
    assert!(b.x > 1e-2 && b.z < -1e-2, "friction drags A along x as the contact pushes it down: {b:?}");
    assert!((a - b).norm() < tol * b.norm(), "across {a:?} against inside {b:?}");
}

#[test]
fn a_contact_across_a_sheared_face_is_the_contact_with_the_sliding_image() {
    let (across, inside) = run_both(sliding_pair(true), sliding_pair(false), 300, None);
    check_sliding_pair(&across, &inside, 1e-9);
}

#[test]
fn a_contact_across_a_sheared_face_is_the_contact_with_the_sliding_image_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_sliding_pair") else { return };
    let (across, inside) = run_both(sliding_pair(true), sliding_pair(false), 300, Some(&ctx));
    // f32 at the contact: the GPU's across against its own inside.
    check_sliding_pair(&across, &inside, 1e-4);
}

/// The rows the device builds across the z faces of a sheared cell (rows.wgsl's search about
/// x less the offset) are the host's (its whole rows of cells there): the strained FCC cell
/// with its images slid 0.37 of a span.
#[test]
fn rows_built_on_the_gpu_for_a_sheared_cell_are_the_hosts() {
    use matdem_engine::backend::gpu::GpuBackend;
    let Some(ctx) = crate::common::gpu("periodic_sheared_rows") else { return };
    let (mut m, a) = strained_fcc(4, 1e-3);
    m.lees_edwards(5.0).unwrap();
    let span = 4.0 * a;
    if let Some(s) = m.effects.periodic.cell.as_mut().and_then(|c| c.shear.as_mut()) {
        s.offset = 0.37 * span * (1.0 - 1e-3);
    }
    matdem_engine::neighbours::rebuild(&mut m);
    let mut gpu = m.clone();
    let mut backend = GpuBackend::prepare(ctx, &gpu).unwrap();
    backend.build_rows_once(&mut gpu).unwrap().expect("the rows fit their slots");
    let (ra, rb) = (&gpu.contacts, &m.contacts);
    let mut across = 0;
    for i in 0..m.len() {
        let (mut x, mut y) = (ra.other[ra.row(i)].to_vec(), rb.other[rb.row(i)].to_vec());
        x.sort_unstable();
        y.sort_unstable();
        assert_eq!(x, y, "row {i}");
        across +=
            y.iter().filter(|&&j| (m.particles.pos[j as usize].z - m.particles.pos[i].z).abs() > 0.5 * span).count();
    }
    assert!(across > 0, "pairs meet through the slid images");
}

/// A dumbbell clump leaving through the top of a sheared cell continues as its image, whole:
/// its body and both members slower by the slide, on both backends.
fn sheared_dumbbell() -> Model {
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e7, 0.2)).unwrap();
    for x in [4.0, 6.0] {
        let i = m.add_particle(Vec3::new(x, 5.0, 9.5) * R, R, k).unwrap();
        m.particles.vel[i] = Vec3::new(0.3, 0.0, 1.0);
    }
    m.periodic([Some([0.0, 12.0 * R]), None, Some([0.0, 12.0 * R])]).unwrap();
    m.clump(&[0, 1]).unwrap();
    m.set_dt(1e-5).unwrap();
    m.lees_edwards(SHEARED_BALL_RATE).unwrap();
    m
}

fn check_sheared_dumbbell(sim: &Simulation, tol: f64) {
    let m = &sim.model;
    let slide = SHEARED_BALL_RATE * 12.0 * R;
    let b = &m.clumps.bodies[0];
    assert!(b.pos.z < 6.0 * R, "the clump crossed the top: {:?}", b.pos);
    for v in [b.vel, m.particles.vel[0], m.particles.vel[1]] {
        assert!((v - Vec3::new(0.3 - slide, 0.0, 1.0)).norm() < tol, "{v:?}, slide {slide}");
    }
    let arm = m.particles.pos[1] - m.particles.pos[0];
    assert!((arm - Vec3::new(2.0 * R, 0.0, 0.0)).norm() < tol * 1e-3, "the members moved with it: {arm:?}");
}

#[test]
fn a_clump_leaving_a_sheared_cell_continues_as_its_image_on_the_cpu_and_the_gpu() {
    let mut cpu = Simulation::new(sheared_dumbbell());
    run(&mut cpu, 300);
    check_sheared_dumbbell(&cpu, 1e-12);
    let Some(ctx) = crate::common::gpu("periodic_lees_edwards_clump") else { return };
    let mut gpu = Simulation::with_gpu(sheared_dumbbell(), ctx);
    run(&mut gpu, 300);
    check_sheared_dumbbell(&gpu, 1e-6);
    // As the ball's, over 300 steps.
    let (a, b) = (cpu.model.clumps.bodies[0].pos, gpu.model.clumps.bodies[0].pos);
    assert!((a - b).norm() < 3e-7, "CPU {a:?} against GPU {b:?}");
}

/// Two balls pressed together, one spinning, with epsd rolling resistance: across a face the
/// rolling spring winds up and brakes the spin as it does inside the cell (CPU to 1e-9 rad/s;
/// the GPU's across against its own inside, f32).
fn rolling_pair(x: f64) -> Model {
    use matdem_engine::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
    let mut m = Model::new();
    let mut mat = material("m", 2650.0, KN, 1e7, 0.2);
    (mat.ks, mat.mu_p) = (4e4, 0.5);
    let k = m.add_material(mat).unwrap();
    for side in [-1.0, 1.0] {
        m.add_particle(Vec3::new(x + side * 0.99 * R, 5.0 * R, 5.0 * R), R, k).unwrap();
    }
    m.settings.rotation = true;
    m.particles.enable_rotation();
    m.particles.rotation.as_mut().unwrap().ang_vel[0] = Vec3::new(0.0, 0.0, 50.0);
    m.periodic([Some([0.0, 10.0 * R]), None, None]).unwrap();
    m.settings.rolling = Some(RollingResistance { model: RollingModel::Epsd, mu_r: 0.3, damping: 0.3 });
    m.set_dt(1e-7).unwrap();
    m
}

fn spins(sim: &Simulation) -> [Vec3; 2] {
    let w = &sim.model.particles.rotation.as_ref().unwrap().ang_vel;
    [w[0], w[1]]
}

#[test]
fn rolling_resistance_across_a_face_brakes_as_inside_the_cell() {
    let (across, inside) = across_and_inside(rolling_pair, 5.0 * R, 2000, None);
    let (a, b) = (spins(&across), spins(&inside));
    eprintln!("across {a:?}\ninside {b:?}");
    assert!(b[0].z < 49.0, "the rolling resistance brakes the spin: {:?}", b[0]);
    for k in 0..2 {
        assert!((a[k] - b[k]).norm() < 1e-9, "{k}: {:?} against {:?}", a[k], b[k]);
    }
}

#[test]
fn rolling_resistance_across_a_face_brakes_as_inside_the_cell_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_rolling_gpu") else { return };
    let (across, inside) = across_and_inside(rolling_pair, 5.0 * R, 2000, Some(&ctx));
    let (a, b) = (spins(&across), spins(&inside));
    eprintln!("across {a:?}\ninside {b:?}");
    assert!(b[0].z < 49.0, "the rolling resistance brakes the spin: {:?}", b[0]);
    for k in 0..2 {
        assert!((a[k] - b[k]).norm() < 1e-3 * 50.0, "{k}: {:?} against {:?}", a[k], b[k]);
    }
}

/// A parallel-bonded pair flying apart at 2 m/s each: across a face the bond (which joins one
/// end to the other's nearest image) stretches and breaks at the step it does inside the cell.
fn parallel_bonded_pair(x: f64) -> Model {
    use matdem_engine::effects::parallel_bond::physics::ParallelBondParams;
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e8, 0.3)).unwrap();
    for (side, v) in [(-1.0, -2.0), (1.0, 2.0)] {
        let i = m.add_particle(Vec3::new(x + side * R, 5.0 * R, 5.0 * R), R, k).unwrap();
        m.particles.vel[i] = Vec3::new(v, 0.3 * side, 0.0);
    }
    m.periodic([Some([0.0, 10.0 * R]), None, None]).unwrap();
    assert_eq!(m.connect(None, 1e-9).unwrap(), 1);
    let p = ParallelBondParams { lambda: 1.0, e_star: 1e9, k_ratio: 2.0, sigma_c: 1e6, cohesion: 1e6, phi: 0.5 };
    assert_eq!(m.bond_parallel(p).unwrap(), 1);
    m.set_dt(1e-8).unwrap();
    m
}

#[test]
fn a_parallel_bond_across_a_face_breaks_as_inside_the_cell() {
    let (mut across, mut inside) =
        (Simulation::new(parallel_bonded_pair(0.0)), Simulation::new(parallel_bonded_pair(5.0 * R)));
    for _ in 0..40 {
        run(&mut across, 10);
        run(&mut inside, 10);
        let (a, b) = (&across.model.particles, &inside.model.particles);
        assert!((a.vel[1] - b.vel[1]).norm() < 1e-9, "{:?} against {:?}", a.vel[1], b.vel[1]);
    }
    let (a, b) = (&across.model.breakages, &inside.model.breakages);
    eprintln!("across {a:?}\ninside {b:?}");
    assert_eq!((a.len(), b.len()), (1, 1), "the bond broke");
    assert_eq!(a[0].step, b[0].step, "at the same step");
}

#[test]
fn a_parallel_bond_across_a_face_breaks_as_inside_the_cell_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_parallel_bond_gpu") else { return };
    let (across, inside) = across_and_inside(parallel_bonded_pair, 5.0 * R, 400, Some(&ctx));
    let (a, b) = (&across.model.breakages, &inside.model.breakages);
    eprintln!("across {a:?}\ninside {b:?}");
    assert_eq!((a.len(), b.len()), (1, 1), "the bond broke");
    assert!(a[0].step.abs_diff(b[0].step) <= 1, "within a step: {} and {}", a[0].step, b[0].step);
}

/// A parallel bond across the z face of a sheared cell, both ends at rest: the image's slide
/// (0.5 m/s) shears the bond, which drags the lower end along x, as it does the bond of the
/// same pair inside an unsheared cell whose far end moves at the slide (`sliding_pair`'s
/// arrangement).
fn sheared_bond(across: bool) -> Model {
    use matdem_engine::effects::parallel_bond::physics::ParallelBondParams;
    let mut m = Model::new();
    let k = m.add_material(material("m", 2650.0, KN, 1e8, 0.3)).unwrap();
    let (za, zb) = if across { (9.0, 1.0) } else { (4.0, 6.0) };
    m.add_particle(Vec3::new(5.0, 5.0, za) * R, R, k).unwrap();
    let b = m.add_particle(Vec3::new(5.0, 5.0, zb) * R, R, k).unwrap();
    m.periodic([Some([0.0, 10.0 * R]), None, Some([0.0, 10.0 * R])]).unwrap();
    assert_eq!(m.connect(None, 1e-9).unwrap(), 1);
    let p = ParallelBondParams { lambda: 1.0, e_star: 1e9, k_ratio: 2.0, sigma_c: 1e6, cohesion: 1e6, phi: 0.5 };
    assert_eq!(m.bond_parallel(p).unwrap(), 1);
    if across {
        m.lees_edwards(SHEARED_BALL_RATE).unwrap();
    } else {
        m.particles.vel[b].x = SHEARED_BALL_RATE * 10.0 * R;
    }
    m.set_dt(1e-8).unwrap();
    m
}

/// Runs the bond across and inside for 1500 steps, comparing the lower end's velocity every
/// 100 (`tol`, of the slide): the bond drags it along x.
fn check_sheared_bond(mut across: Simulation, mut inside: Simulation, tol: f64) {
    let mut fastest: f64 = 0.0;
    for _ in 0..15 {
        run(&mut across, 100);
        run(&mut inside, 100);
        let (a, b) = (across.model.particles.vel[0], inside.model.particles.vel[0]);
        assert!((a - b).norm() <= tol * SHEARED_BALL_RATE * 10.0 * R, "{a:?} against {b:?}");
        fastest = fastest.max(b.x);
    }
    assert!(fastest > 0.05, "the bond drags the lower end along: {fastest} m/s at most");
    assert!(across.model.breakages.is_empty() && inside.model.breakages.is_empty(), "the bond holds");
}

#[test]
fn a_parallel_bond_across_a_sheared_face_shears_as_with_the_sliding_image() {
    check_sheared_bond(Simulation::new(sheared_bond(true)), Simulation::new(sheared_bond(false)), 1e-9);
}

#[test]
fn a_parallel_bond_across_a_sheared_face_shears_as_with_the_sliding_image_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_sheared_bond") else { return };
    let (across, inside) =
        (Simulation::with_gpu(sheared_bond(true), ctx.clone()), Simulation::with_gpu(sheared_bond(false), ctx));
    // f32 in the bond: the GPU's across against its own inside. The stretch the bond's turn
    // adds (~1e-8 m) is some ten f32 ulps of the positions, so the small v_z it drives agrees
    // to about 1 % (measured on lavapipe: 7e-6 of the slide at worst).
    check_sheared_bond(across, inside, 1e-4);
}

/// Heat conduction across a face: four bonded elements in a row straddling the face, held in
/// place, at 0, 0, 1, 1 K, exchange heat through the face as they do mid-cell (CPU to 1e-12 K;
/// the GPU's across against its own mid-cell, f32). Moisture runs the same diffusion core.
fn warm_row(x: f64) -> Model {
    use matdem_engine::effects::conduction::ThermalProps;
    use matdem_engine::state::particles::dof;
    let mut m = Model::new();
    let k = m.add_material(material("rod", 1000.0, 1.0, 1.0, 0.0)).unwrap();
    for i in 0..4 {
        // Pressed a little together: a touching pair's conductance is its contact's.
        m.add_particle(Vec3::new(x + (2.0 * i as f64 - 3.0) * 0.99 * R, 5.0 * R, 5.0 * R), R, k).unwrap();
    }
    m.periodic([Some([0.0, 12.0 * R]), None, None]).unwrap();
    m.connect(None, 1e-9).unwrap();
    m.fix(&[0, 1, 2, 3], dof::ALL, true).unwrap();
    m.settings.heat.reference = 0.0;
    m.enable_heat();
    m.set_thermal_material("rod", ThermalProps { conductivity: 1.0, specific_heat: 1.0, expansion: 0.0 }).unwrap();
    m.set_temperatures(&[0.0, 0.0, 1.0, 1.0]).unwrap();
    m.clock.dt = 1e-4;
    m
}

fn temperatures(sim: &Simulation) -> Vec<f64> {
    sim.model.particles.thermal.temperature.clone()
}

#[test]
fn heat_flows_across_a_face_as_inside_the_cell() {
    let (across, inside) = across_and_inside(warm_row, 6.0 * R, 500, None);
    let (a, b) = (temperatures(&across), temperatures(&inside));
    eprintln!("across {a:?}\ninside {b:?}");
    assert!(b[1] > 0.01 && b[2] < 0.99, "heat flowed: {b:?}");
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-12, "{a:?} against {b:?}");
    }
}

#[test]
fn heat_flows_across_a_face_as_inside_the_cell_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_heat_gpu") else { return };
    let (across, inside) = across_and_inside(warm_row, 6.0 * R, 500, Some(&ctx));
    let (a, b) = (temperatures(&across), temperatures(&inside));
    eprintln!("across {a:?}\ninside {b:?}");
    assert!(b[1] > 0.01 && b[2] < 0.99, "heat flowed: {b:?}");
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-5, "{a:?} against {b:?}");
    }
}

/// Two dumbbell clumps (two touching spheres each, the second's tilted in z so the blow turns
/// them) meeting at `x` in a periodic cell [0, 16R) in x, no gravity. At x = 2R the first
/// clump's centre starts 0.1R below the face: it crosses the face before they touch (0.118R of
/// travel) and again after they part.
fn dumbbells(x: f64) -> Model {
    let mut m = Model::new();
    let mut mat = material("m", 2650.0, KN, 1e7, 0.3);
    mat.restitution = 0.6;
    let k = m.add_material(mat).unwrap();
    let centres = [
        (Vec3::new(x - 3.1 * R, 5.0 * R, 5.0 * R), 0.5),
        (Vec3::new(x - 1.1 * R, 5.0 * R, 5.0 * R), 0.5),
        (Vec3::new(x + 1.1 * R, 5.0 * R, 5.4 * R), -0.5),
        (Vec3::new(x + 3.0 * R, 5.0 * R, 4.8 * R), -0.5),
    ];
    for (c, v) in centres {
        let i = m.add_particle(c, R, k).unwrap();
        m.particles.vel[i] = Vec3::new(v, 0.01, 0.0);
    }
    m.periodic([Some([0.0, 16.0 * R]), None, None]).unwrap();
    m.clump(&[0, 1]).unwrap();
    m.clump(&[2, 3]).unwrap();
    m.set_dt(1e-6).unwrap();
    m
}

/// Clumps across a face collide as inside the cell: each body's velocity and angular momentum
/// after the blow agree (`tol`, m/s and per unit of the blow's angular momentum), the first
/// clump's centre came back into the cell, and its members moved with it.
fn check_dumbbells(across: &Simulation, inside: &Simulation, tol: f64) {
    let (a, b) = (&across.model.clumps.bodies, &inside.model.clumps.bodies);
    eprintln!("across {:?} {:?}\ninside {:?} {:?}", a[0].vel, a[0].ang_mom, b[0].vel, b[0].ang_mom);
    assert!(b[0].vel.x < -0.1, "the inside clumps bounced: {:?}", b[0].vel);
    let l = b.iter().map(|x| x.ang_mom.norm()).fold(0.0, f64::max);
    assert!(l > 0.0, "the blow turned them");
    for c in 0..2 {
        assert!((a[c].vel - b[c].vel).norm() < tol, "clump {c}: {:?} against {:?}", a[c].vel, b[c].vel);
        assert!(
            (a[c].ang_mom - b[c].ang_mom).norm() < tol * l,
            "clump {c}: L {:?} against {:?}",
            a[c].ang_mom,
            b[c].ang_mom
        );
    }
    // Back in the cell, and rigid: the members where the body carries them.
    let x = a[0].pos.x;
    assert!((0.0..16.0 * R).contains(&x), "the centre is in the cell: {x}");
    let p = &across.model.particles;
    let arm = (p.pos[0] - p.pos[1]).norm();
    assert!((arm - 2.0 * R).abs() < 1e-4 * R, "the members stayed together: {arm}");
}

#[test]
fn clumps_across_a_face_collide_as_inside_the_cell() {
    let (across, inside) = run_both(dumbbells(2.0 * R), dumbbells(8.0 * R), 3000, None);
    check_dumbbells(&across, &inside, 1e-9);
}

#[test]
fn clumps_across_a_face_collide_as_inside_the_cell_on_the_gpu() {
    let Some(ctx) = crate::common::gpu("periodic_clumps_gpu") else { return };
    let (across, inside) = run_both(dumbbells(2.0 * R), dumbbells(8.0 * R), 3000, Some(&ctx));
    // f32 at the contacts: the GPU's across against its own inside.
    check_dumbbells(&across, &inside, 1e-4);
}

// The gases' parity horizons against rounding alone: each gas run on the CPU beside three rounded
// twins (each position and velocity one rounding away, `rounded_twin`) parts by less than a
// third of the 1e-3 of the largest move the parity tests above allow after their 300 steps
// (measured: at most 1.4e-7), so those hold for any device's rounding, not only for the one
// they were measured on. (A twin's positions start one rounding away: its displacements count.)
#[test]
fn the_gases_parity_horizons_hold_under_f32_rounding() {
    let sheared: fn() -> Model = || sheared_gas(20.0);
    let scenes = [("gas", gas as fn() -> Model), ("sheared gas", sheared), ("sheared 2D gas", sheared_disc_gas)];
    for (name, scene) in scenes {
        for seed in 1..=3 {
            let (mut a, mut b) =
                (Simulation::new(scene()), Simulation::new(crate::common::rounded_twin(scene(), seed)));
            run(&mut a, 300);
            run(&mut b, 300);
            let (moved, _, disp) = divergence(&a.model.particles, &b.model.particles);
            assert!(
                disp < 1e-3 / 3.0 * moved,
                "{name}, twin {seed}: displacements part by {disp:e} of {moved:e} m moved"
            );
        }
    }
}
