//! The energy account on the GPU backend (f32): kinetic + elastic + gravity + heat − wall work
//! stays what it was, and each cause's heat equals the CPU backend's (f64) on the same scene.
//!
//! Every scene runs on the GPU in several runs, so the device's ledger is folded into the
//! model's at several downloads. Tolerances: the account within 1e-3 of the scene's energy
//! scale (f32 state and heat); a cause's heat within 1e-3 of the CPU's where the scene is a
//! single smooth contact, wider (stated) where the moment of a stick–slip change or of a
//! break, crossed in f32, moves it.
//!
//! Without a GPU adapter each test prints a note and passes, unless MATDEM_REQUIRE_GPU=1.
#![cfg(feature = "gpu")]

use crate::common::{damped_glass_pair, gpu, material, rel, run, two_spheres, GLASS_R};
use matdem_engine::backend::gpu::device::GpuContext;
use matdem_engine::status::Energies;
use matdem_engine::{Material, Model, NormalKind, Simulation, Vec3, Wall, WallMotion};
use std::sync::Arc;

/// The account of a scene at the start and at the end on each backend.
struct Accounts {
    start: Energies,
    cpu: Energies,
    gpu: Energies,
}

/// Runs `model` for `pieces` runs of `steps` steps on both backends.
fn run_both(model: Model, ctx: &Arc<GpuContext>, pieces: u64, steps: u64) -> (Accounts, Simulation, Simulation) {
    let mut cpu = Simulation::new(model.clone());
    let mut gpu = Simulation::with_gpu(model, ctx.clone());
    let start = cpu.energies();
    for _ in 0..pieces {
        run(&mut cpu, steps).unwrap();
        run(&mut gpu, steps).unwrap();
    }
    (Accounts { start, cpu: cpu.energies(), gpu: gpu.energies() }, cpu, gpu)
}

impl Accounts {
    /// The GPU's (and the CPU's) total stayed within `tol`·`scale` of the start.
    fn assert_conserved(&self, name: &str, scale: f64, tol: f64) {
        let (e0, c, g) = (self.start.total(), self.cpu.total(), self.gpu.total());
        eprintln!(
            "{name}: total start {e0:.9e}, cpu {c:.9e}, gpu {g:.9e}; scale {scale:.3e}\n  cpu {:?}\n  gpu {:?}",
            self.cpu, self.gpu
        );
        assert!((c - e0).abs() < tol * scale, "{name}: the CPU account moved by {:.3e} of the scale", (c - e0) / scale);
        assert!((g - e0).abs() < tol * scale, "{name}: the GPU account moved by {:.3e} of the scale", (g - e0) / scale);
    }

    /// One cause: positive on the CPU and the GPU's within `tol` of it.
    fn assert_cause(&self, name: &str, cause: &str, f: fn(&Energies) -> f64, tol: f64) {
        let (c, g) = (f(&self.cpu), f(&self.gpu));
        eprintln!("{name}: {cause} cpu {c:.9e}, gpu {g:.9e}, rel {:.2e}", rel(g, c));
        assert!(c > 0.0, "{name}: the scene must produce {cause}");
        assert!(rel(g, c) < tol, "{name}: GPU {cause} {g:e} vs CPU {c:e}");
    }
}

// (a) A damped Hertz impact: two glass spheres (r 1 cm, 1 m/s each) with restitution 0.5, a
// dashpot on the Hertz law; 3 runs of 300 steps at t_c/200, ending in free flight. The
// account within 1e-3 of the initial kinetic energy; the dashpot's heat within 1e-3 of the
// CPU's and ≈ (1 − e²) of the kinetic energy (the Hertz dashpot gives e to within a few %).
#[test]
fn damped_hertz_impact_books_dashpot_heat_like_cpu() {
    let Some(ctx) = gpu("damped_hertz_impact") else { return };
    let model = damped_glass_pair();
    let (a, _, gpu) = run_both(model, &ctx, 3, 300);
    let k0 = a.start.kinetic;
    a.assert_conserved("hertz impact", k0, 1e-3);
    a.assert_cause("hertz impact", "dashpot heat", |e| e.heat_contact_damping, 1e-3);
    let share = a.gpu.heat_contact_damping / k0;
    assert!((share - 0.75).abs() < 0.05, "dashpot heat {share:.4} of the kinetic energy, expected ≈ 0.75");
    assert!(gpu.model.contacts.state.iter().all(|s| s.dashpot == 0.0), "apart: no dashpot force is left");
}

// The dashpot force comes back from the device: stopped in mid-contact, the GPU's model holds
// the CPU's stored dashpot force (pairs and walls, within 1e-3), so a CPU run that follows
// continues the trapezoid: its heat equals the all-CPU run's within 1e-4.
#[test]
fn dashpot_force_survives_a_download_mid_contact() {
    let Some(ctx) = gpu("dashpot_mid_contact") else { return };
    let mut model = damped_glass_pair();
    // A floor the right sphere rests on, so a wall contact is caught mid-contact too.
    model.add_wall(Wall::plane("floor", Vec3::new(0.0, 0.0, -GLASS_R - 1e-6), Vec3::z(), 1.0).unwrap()).unwrap();
    model.particles.vel[1].z = -1.0;
    let mut cpu = Simulation::new(model.clone());
    let mut gpu = Simulation::with_gpu(model, ctx);
    run(&mut cpu, 60).unwrap();
    run(&mut gpu, 60).unwrap();
    let stored = |s: &Simulation| {
        let pair = s.model.contacts.state.iter().map(|p| p.dashpot).find(|&d| d != 0.0).unwrap_or(0.0);
        let wall = s.model.wall_contacts.iter().map(|p| p.dashpot).find(|&d| d != 0.0).unwrap_or(0.0);
        (f64::from(pair), f64::from(wall))
    };
    let (c, g) = (stored(&cpu), stored(&gpu));
    eprintln!("dashpot forces (pair, wall): cpu {c:?}, gpu {g:?}");
    assert!(c.0 != 0.0 && c.1 != 0.0, "both contacts must be closed at the download");
    assert!(rel(g.0, c.0) < 1e-3 && rel(g.1, c.1) < 1e-3);
    let mut cont = Simulation::new(gpu.model.clone());
    run(&mut cpu, 500).unwrap();
    run(&mut cont, 500).unwrap();
    let (hc, hg) = (cpu.energies().heat_contact_damping, cont.energies().heat_contact_damping);
    eprintln!("dashpot heat: all cpu {hc:.9e}, gpu then cpu {hg:.9e}");
    assert!(rel(hg, hc) < 1e-4, "dashpot heat {hg:e} after a GPU start vs {hc:e}");
}

/// Steel spheres with a shear spring and friction μ, no dashpot.
fn steel(mu: f64) -> Material {
    let mut mat = material("steel", 7800.0, 1e6, 2e11, 0.3);
    mat.ks = 4e5;
    mat.mu_p = mu;
    mat
}

// (b) Friction. Two spheres (r 5 mm) meet obliquely (normal 0.1 m/s, tangential 1 m/s each,
// rotation on, no dashpot): they slide through the contact. And a sphere set sliding at
// 0.1 m/s on a floor (resting at its equilibrium overlap, gravity, μ 0.5) slides until it
// rolls: a rolling sphere keeps 5/7 of the kinetic energy, so friction takes 2/7 of it.
// Accounts within 1e-3 of the initial kinetic energy; friction heat within 1e-3 of the CPU's
// (collision) and 1e-2 (the floor: when the slip ends is decided in f32); floor heat 2/7 of
// the kinetic energy within 2% (the shear spring and the floor's elastic bounce hold a little).
#[test]
fn sliding_grains_book_friction_heat_like_cpu() {
    let Some(ctx) = gpu("sliding_grains") else { return };
    let r = 0.005;
    let mut pair = two_spheres(steel(0.3), r, 1e-6, 0.1, NormalKind::Linear);
    pair.settings.rotation = true;
    pair.particles.vel[0].y = 1.0;
    pair.particles.vel[1].y = -1.0;
    let m = pair.particles.mass[0];
    pair.set_dt(std::f64::consts::PI * (m / 2e6).sqrt() / 100.0).unwrap();
    let (a, _, _) = run_both(pair, &ctx, 3, 200);
    a.assert_conserved("oblique collision", a.start.kinetic, 1e-3);
    a.assert_cause("oblique collision", "friction heat", |e| e.heat_friction, 1e-3);

    let mut floor = Model::new();
    floor.settings.rotation = true;
    floor.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    let k = floor.add_material(steel(0.5)).unwrap();
    floor.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
    let sag = m * 9.81 / 2e6; // the sphere–wall spring is the material's in series with a rigid wall: 2·kn
    let id = floor.add_particle(Vec3::new(0.0, 0.0, r - sag), r, k).unwrap();
    floor.particles.vel[id].x = 0.1;
    floor.set_dt(2.0 * std::f64::consts::PI * (m / 2e6).sqrt() / 50.0).unwrap();
    let (a, _, gpu) = run_both(floor, &ctx, 4, 500);
    let k0 = a.start.kinetic;
    a.assert_conserved("sliding on a floor", k0, 1e-3);
    a.assert_cause("sliding on a floor", "friction heat", |e| e.heat_friction, 1e-2);
    let share = a.gpu.heat_friction / k0;
    assert!((share - 2.0 / 7.0).abs() < 0.02 * 2.0 / 7.0, "friction took {share:.4} of the kinetic energy");
    let w = gpu.model.particles.rotation.as_ref().unwrap().ang_vel[id].y;
    assert!(rel(w * r, gpu.model.particles.vel[id].x) < 1e-2, "the sphere must end rolling");
}

// (c) A bonded block torn apart: a 3×3×4 simple cubic block of bonded elements (r 1 cm,
// Kn 1e6 N/m, Xb 1e-5 m, Fs0 5 N, μ 0.5), its upper half moving up and its lower half down
// at 0.5 m/s, no walls, no gravity; 4 runs of 500 steps. The bonds between the halves break
// (the GPU as many as the CPU); the account within 1e-3 of the initial kinetic energy; the
// breakage heat within 2% of the CPU's (a break's heat is that of the step it happens at,
// which f32 may move by one).
#[test]
fn torn_bonded_block_books_breakage_heat_like_cpu() {
    let Some(ctx) = gpu("torn_block") else { return };
    let mut mat = steel(0.5);
    mat.density = 2650.0;
    mat.ks = 1e6;
    mat.xb = 1e-5;
    mat.fs0 = 5.0;
    let mut m = Model::new();
    let k = m.add_material(mat).unwrap();
    let r = 0.01;
    for x in matdem_engine::builder::simple_cubic(3, 3, 4, 2.0 * r, Vec3::repeat(r)) {
        let id = m.add_particle(x, r, k).unwrap();
        m.particles.vel[id].z = if x.z > 4.0 * r { 0.5 } else { -0.5 };
    }
    let bonds = m.connect(None, 1e-9).unwrap();
    m.set_dt(1e-6).unwrap();
    let (a, cpu, gpu) = run_both(m, &ctx, 4, 500);
    let (bc, bg) = (cpu.model.breakages.len(), gpu.model.breakages.len());
    eprintln!("{bonds} bonds; broke: cpu {bc}, gpu {bg}");
    assert!(bc >= 9 && bc == bg, "the 9 bonds between the halves (at least) must break on both");
    a.assert_conserved("torn block", a.start.kinetic, 1e-3);
    a.assert_cause("torn block", "breakage heat", |e| e.heat_breakage, 2e-2);
}

// (d) Damping. Viscous: four free spheres (no contacts) moving at 0.1–0.4 m/s, damped for
// 4 runs of 5000 steps so that their kinetic energy falls by about 45%: each
// step's heat is ~1e-5 of what has been booked, where a plain f32 running sum would drift
// by up to ~1e-3. Local: a sphere falling under gravity with Cundall's damping 0.3 for 2
// runs of 5000 steps. And four spheres spinning in place, damped to e^−10 of their energy in
// one run of 20000 steps: the last steps' heat is below half an f32 ulp of the booked total,
// which a plain f32 sum drops (measured on lavapipe: the account then moves by 1.8e-5 of the
// energy; with the compensated sum by 7e-7). Accounts within 1e-4 of the scene's energy (1e-5 for the spin, 1e-3 for the fall:
// see there); the damping heat within 1e-4 of the CPU's (1e-5 for the spin).
#[test]
fn viscous_and_local_damping_heat_is_kept_to_f32_precision() {
    let Some(ctx) = gpu("damping_heat") else { return };
    let mut m = Model::new();
    let k = m.add_material(steel(0.0)).unwrap();
    for i in 0..4 {
        let id = m.add_particle(Vec3::new(0.1 * i as f64, 0.0, 0.0), 0.005, k).unwrap();
        m.particles.vel[id] = Vec3::new(0.0, 0.1 * (i + 1) as f64, 0.05);
    }
    let dt = m.set_standard_dt().unwrap();
    // The kinetic energy falls as exp(−4ζω·t): by about 45% over the 20000 steps.
    let omega = (m.element_stiffness(0) / m.particles.mass[0]).sqrt();
    m.settings.damping = 0.15 / (omega * dt * 20000.0);
    let (a, _, _) = run_both(m, &ctx, 4, 5000);
    let k0 = a.start.kinetic;
    assert!(
        a.gpu.kinetic < 0.7 * k0 && a.gpu.kinetic > 0.4 * k0,
        "kinetic energy {:.3} of the start",
        a.gpu.kinetic / k0
    );
    a.assert_conserved("viscous damping", k0, 1e-4);
    a.assert_cause("viscous damping", "damping heat", |e| e.heat_damping, 1e-4);

    // Spinning in place, the rows never go stale: one download at the end of 20000 steps.
    let mut m = Model::new();
    m.settings.rotation = true;
    let k = m.add_material(steel(0.0)).unwrap();
    for i in 0..4 {
        m.add_particle(Vec3::new(0.1 * i as f64, 0.0, 0.0), 0.005, k).unwrap();
    }
    m.particles.enable_rotation();
    for (i, w) in m.particles.rotation.as_mut().unwrap().ang_vel.iter_mut().enumerate() {
        *w = Vec3::new(10.0, 5.0 * i as f64, 0.0);
    }
    let dt = m.set_standard_dt().unwrap();
    // The spin's energy falls as exp(−4ζω·t): to e^−10 over the run.
    let omega = (m.element_stiffness(0) / m.particles.mass[0]).sqrt();
    m.settings.damping = 10.0 / (4.0 * omega * dt * 20000.0);
    let (a, _, _) = run_both(m, &ctx, 1, 20000);
    a.assert_conserved("damped spin", a.start.kinetic, 1e-5);
    a.assert_cause("damped spin", "damping heat", |e| e.heat_damping, 1e-5);

    let mut m = Model::new();
    let k = m.add_material(steel(0.0)).unwrap();
    m.add_particle(Vec3::zeros(), 0.005, k).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m.settings.local_damping = 0.3;
    m.set_standard_dt().unwrap();
    let (a, _, gpu) = run_both(m, &ctx, 2, 5000);
    let fall = -gpu.model.particles.pos[0].z * 9.81 * gpu.model.particles.mass[0];
    // Cundall's heat is booked at the half-step velocity, the account's kinetic energy too:
    // on either backend the account moves by ~1e-4 of the fall.
    a.assert_conserved("local damping", fall, 1e-3);
    a.assert_cause("local damping", "damping heat", |e| e.heat_damping, 1e-4);
    assert!(rel(a.gpu.heat_damping, 0.3 * fall) < 1e-3, "local damping takes α of the fall's energy");
}

// (e) A moving platen: eight spheres (r 1 mm, 2×2×2, touching) on a floor, a platen resting
// on them pressed down at 0.01 m/s for 3 runs of 1000 steps, with contact dashpots
// (restitution 0.5) and viscous damping 0.05. Mechanical + heat − wall work within 1e-3 of
// the platen's work; the wall work and the dashpot heat within 1e-3 of the CPU's.
#[test]
fn moving_platen_work_is_booked_like_cpu() {
    let Some(ctx) = gpu("moving_platen") else { return };
    let r = 0.001;
    let mut mat = material("grain", 2650.0, 1e5, 1e9, 0.3);
    mat.ks = 4e4;
    mat.mu_p = 0.5;
    mat.restitution = 0.5;
    let mut m = Model::new();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m.settings.damping = 0.05;
    let k = m.add_material(mat).unwrap();
    for x in matdem_engine::builder::simple_cubic(2, 2, 2, 2.0 * r, Vec3::repeat(r)) {
        m.add_particle(x, r, k).unwrap();
    }
    let area = 16.0 * r * r;
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), area).unwrap()).unwrap();
    let mut platen = Wall::plane("platen", Vec3::new(0.0, 0.0, 4.0 * r), -Vec3::z(), area).unwrap();
    platen.motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -0.01));
    m.add_wall(platen).unwrap();
    m.set_standard_dt().unwrap();
    let (a, _, _) = run_both(m, &ctx, 3, 1000);
    let work = a.cpu.wall_work;
    assert!(work > 0.0, "the platen must do work");
    a.assert_conserved("moving platen", work, 1e-3);
    a.assert_cause("moving platen", "wall work", |e| e.wall_work, 1e-3);
    a.assert_cause("moving platen", "dashpot heat", |e| e.heat_contact_damping, 1e-3);
}
