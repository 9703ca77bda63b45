//! Rolling resistance (the `rolling_resistance` stage, effects/rolling_resistance/physics.rs) against
//! closed-form answers, on a solid sphere (r = 1 cm, 2650 kg/m³, linear springs kn = 1e5 N/m,
//! ks = 5e4 N/m, μ = 0.5, e = 1) on a rigid plane wall, which the engine supports directly
//! (R_eff = r, I_eff = I = 2/5·m·r²):
//!
//! - cdt, rolling at v0 on a level plane: the torque μ_r·r·m·g and the friction that keeps the
//!   sphere rolling decelerate it at a = μ_r·g·m·r²/(I + m·r²) = 5/7·μ_r·g, so it stops after
//!   t = v0/a, having travelled v0²/(2a); the energy it loses, 7/10·m·v0², is what the torque
//!   did over the rolling angle, μ_r·m·g·d;
//! - epsd on a slope of angle θ: at rest the spring must carry m·g·sinθ·r, at most
//!   μ_r·r·m·g·cosθ, so the sphere stays for tanθ ≤ μ_r and rolls away above, at
//!   a = 5/7·g·cosθ·(tanθ − μ_r);
//! - both models on the GPU against the CPU's (the same roll, slope and pile), and the device's
//!   row builds carrying epsd's springs.

use crate::common::{material, rel};
use matdem_engine::backend::RunControl;
use matdem_engine::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
use matdem_engine::plan::Stage;
use matdem_engine::{Model, NormalKind, Simulation, Vec3, Wall};

const R: f64 = 0.01;
const G: f64 = 9.81;

/// The sphere on the plane z = 0 under gravity tilted by `slope` (rad) about y (the slope runs
/// down along +x), resting at its equilibrium overlap, rolling along +x at `v0` without slip.
fn ball(rolling: Option<RollingResistance>, slope: f64, v0: f64) -> Model {
    let mut mat = material("ball", 2650.0, 1e5, 1e9, 0.2);
    mat.ks = 5e4;
    mat.mu_p = 0.5;
    let mut m = Model::new();
    m.settings.normal = NormalKind::Linear;
    let k = m.add_material(mat).unwrap();
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
    let mass = 2650.0 * 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
    // Against a rigid wall the element's own spring acts, twice the pair's kn.
    let a = m.add_particle(Vec3::new(0.0, 0.0, R - mass * G * slope.cos() / 2e5), R, k).unwrap();
    m.settings.gravity = Vec3::new(G * slope.sin(), 0.0, -G * slope.cos());
    m.settings.rotation = true;
    m.particles.enable_rotation();
    m.particles.vel[a] = Vec3::new(v0, 0.0, 0.0);
    m.particles.rotation.as_mut().unwrap().ang_vel[a] = Vec3::new(0.0, v0 / R, 0.0);
    m.settings.rolling = rolling;
    m.set_standard_dt().unwrap();
    m
}

fn cdt(mu_r: f64) -> Option<RollingResistance> {
    Some(RollingResistance::new(RollingModel::Cdt, mu_r, 0.0).unwrap())
}

fn epsd(mu_r: f64, damping: f64) -> Option<RollingResistance> {
    Some(RollingResistance::new(RollingModel::Epsd, mu_r, damping).unwrap())
}

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

/// What a roll to rest measured: the time vx first reached 0 (interpolated between samples 10
/// steps apart), the distance travelled once at rest, and the deceleration fitted over
/// 0.9·v0 ≥ vx ≥ 0.2·v0.
struct Stop {
    time: f64,
    distance: f64,
    deceleration: f64,
    /// Mechanical energy lost (J) and the largest rise of it between samples (J).
    lost: f64,
    rise: f64,
    /// Heat the ledger booked, and the largest departure of mechanical + heat from its start (J).
    heat: f64,
    drift: f64,
}

fn roll_to_rest(mut sim: Simulation, v0: f64, until: f64) -> Stop {
    let x0 = sim.model.particles.pos[0].x;
    let dt = sim.model.clock.dt;
    let (mut time, mut last) = (None, (0.0, v0));
    let (mut fit, mut rise) = (Vec::new(), 0.0_f64);
    let e0 = sim.energies().mechanical();
    let (total0, mut drift) = (sim.energies().total(), 0.0_f64);
    let mut e_last = e0;
    while sim.model.clock.time < until {
        run(&mut sim, 10);
        let (t, v) = (sim.model.clock.time - 0.5 * dt, sim.model.particles.vel[0].x);
        if time.is_none() && v <= 0.0 {
            time = Some(last.0 + (t - last.0) * last.1 / (last.1 - v));
        }
        if (0.2 * v0..=0.9 * v0).contains(&v) {
            fit.push((t, v));
        }
        last = (t, v);
        let e = sim.energies().mechanical();
        rise = rise.max(e - e_last);
        e_last = e;
        drift = drift.max((sim.energies().total() - total0).abs());
    }
    // Least squares slope of v(t).
    let k = fit.len() as f64;
    let (st, sv) = fit.iter().fold((0.0, 0.0), |(a, b), (t, v)| (a + t, b + v));
    let (mt, mv) = (st / k, sv / k);
    let (num, den) = fit.iter().fold((0.0, 0.0), |(a, b), (t, v)| (a + (t - mt) * (v - mv), b + (t - mt).powi(2)));
    Stop {
        time: time.expect("the sphere stopped"),
        distance: sim.model.particles.pos[0].x - x0,
        deceleration: -num / den,
        lost: e0 - e_last,
        rise,
        heat: sim.energies().heat(),
        drift,
    }
}

// cdt on a level plane, μ_r = 0.1, v0 = 0.2 m/s: a = 5/7·μ_r·g = 0.7007 m/s², t = 0.2854 s,
// d = 28.54 mm, energy lost 7/10·m·v0².
#[test]
fn cdt_sphere_rolls_to_rest_at_five_sevenths_mu_r_g() {
    let (mu_r, v0) = (0.1, 0.2);
    let a = 5.0 / 7.0 * mu_r * G;
    let mut sim = Simulation::new(ball(cdt(mu_r), 0.0, v0));
    assert!(sim.plan().has(Stage::RollingResistance));
    let mass = sim.model.particles.mass[0];
    let s = roll_to_rest(sim, v0, 1.5 * v0 / a);
    let lost = 0.7 * mass * v0 * v0;
    eprintln!(
        "cdt roll: a {:.5} m/s² (analytic {a:.5}), stop at {:.5} s ({:.5}), distance {:.6} m ({:.6}), energy lost \
         {:.5e} J ({lost:.5e}), largest rise between samples {:.2e} J",
        s.deceleration,
        s.time,
        v0 / a,
        s.distance,
        v0 * v0 / (2.0 * a),
        s.lost,
        s.rise
    );
    assert!(rel(s.deceleration, a) < 0.01, "deceleration");
    assert!(rel(s.time, v0 / a) < 0.01, "stopping time");
    assert!(rel(s.distance, v0 * v0 / (2.0 * a)) < 0.01, "stopping distance");
    // Rolling resistance only takes energy: what it took is the rolling energy, and the account
    // never rises by more than the elastic exchange of the springs' round-off.
    assert!(rel(s.lost, lost) < 0.01, "energy lost");
    assert!(s.rise < 1e-6 * lost, "mechanical energy rose by {:e} J", s.rise);
    // The ledger books what the torque took as friction heat: the account closes.
    eprintln!("cdt roll: heat booked {:.6e} J, mechanical + heat drifted by at most {:.2e} J", s.heat, s.drift);
    assert!(rel(s.heat, s.lost) < 1e-3, "heat booked {:e} J against {:e} J lost", s.heat, s.lost);
    assert!(s.drift < 1e-3 * lost, "mechanical + heat drifted by {:e} J", s.drift);
}

// Without rolling resistance the sphere keeps rolling: the stage, not something else, stops it.
#[test]
fn without_rolling_resistance_the_sphere_keeps_rolling() {
    let mut sim = Simulation::new(ball(None, 0.0, 0.2));
    assert!(!sim.plan().has(Stage::RollingResistance));
    let off = |sim: &mut Simulation| sim.plan().to_string().split("not simulated:").nth(1).unwrap().to_string();
    assert_eq!(off(&mut sim).matches("rolling resistance").count(), 1, "listed once as not simulated");
    let mut on = Simulation::new(ball(cdt(0.1), 0.0, 0.2));
    let words = off(&mut on);
    assert!(!words.contains("rolling resistance"), "a stage that runs is not listed as off: {words}");
    run(&mut sim, 2000);
    assert!(rel(sim.model.particles.vel[0].x, 0.2) < 1e-3);
}

/// The sphere released at rest on a slope of `slope` rad with epsd μ_r = 0.1, η_r = 0.3, on the
/// backend `sim` puts it on: the distance it has rolled after `t` s, and its speed.
fn slope_run_on(sim: impl Fn(Model) -> Simulation, slope: f64, t: f64) -> (f64, f64) {
    let mut sim = sim(ball(epsd(0.1, 0.3), slope, 0.0));
    let steps = (t / sim.model.clock.dt).round() as u64;
    run(&mut sim, steps);
    (sim.model.particles.pos[0].x, sim.model.particles.vel[0].x)
}

// epsd, μ_r = 0.1: θ_c = atan 0.1 = 5.71°. At 0.8·θ_c the sphere creeps only the spring's
// elastic deflection (sub-micrometre) and comes to rest; at 1.2·θ_c it rolls away with
// a = 5/7·g·cosθ·(tanθ − μ_r).
#[test]
fn epsd_holds_a_sphere_below_the_critical_slope_and_lets_it_roll_above() {
    check_slope(Simulation::new);
}

fn check_slope(slope_run: impl Fn(Model) -> Simulation + Copy) {
    let slope_run = |slope, t| slope_run_on(slope_run, slope, t);
    let theta_c = 0.1_f64.atan();
    let (t1, t2) = (0.3, 0.6);
    let below = 0.8 * theta_c;
    let (x1, _) = slope_run(below, t1);
    let (x2, v2) = slope_run(below, t2);
    eprintln!("θ = 0.8·θc: x {x1:.3e} m at {t1} s, {x2:.3e} m at {t2} s, v {v2:.2e} m/s");
    assert!(x2.abs() < 1e-6 && (x2 - x1).abs() < 1e-8 && v2.abs() < 1e-6, "held below θc");

    let above = 1.2 * theta_c;
    let a = 5.0 / 7.0 * G * above.cos() * (above.tan() - 0.1);
    let (x1, _) = slope_run(above, t1);
    let (x2, _) = slope_run(above, t2);
    // From rest: x = a·t²/2 (after a transient of microseconds), so a = 2(x2 − x1)/(t2² − t1²).
    let measured = 2.0 * (x2 - x1) / (t2 * t2 - t1 * t1);
    eprintln!("θ = 1.2·θc: a {measured:.5} m/s² (analytic {a:.5}), x {x2:.4e} m at {t2} s");
    assert!(rel(measured, a) < 0.01, "rolls away above θc");
}

// epsd rolling down a slope above θ_c: its spring slips at the cap and its dashpot works while
// it loads; the ledger books the torque's work as friction heat, so mechanical + heat stays
// put (to the rolling spring's stored energy, (μ_r·r·m·g)²/(2·k_r) ≈ 1e-9 J, at most).
#[test]
fn epsd_rolling_work_closes_the_energy_account() {
    let mut sim = Simulation::new(ball(epsd(0.1, 0.3), 1.2 * 0.1_f64.atan(), 0.0));
    let e0 = sim.energies();
    let steps = (0.3 / sim.model.clock.dt) as u64;
    run(&mut sim, steps);
    let e = sim.energies();
    let (lost, heat) = (e0.mechanical() - e.mechanical(), e.heat());
    eprintln!("epsd slope: mechanical lost {lost:.6e} J, heat booked {heat:.6e} J");
    assert!(heat > 0.0 && rel(heat, lost) < 1e-3, "heat booked {heat:e} J against {lost:e} J lost");
}

// Stage off: a plan whose μ_r is 0 has no stage and moves bit for bit as one without the
// setting; epsd's springs exist only with epsd (one per row entry and per wall, as the plan says).
#[test]
fn the_stage_costs_nothing_when_off_and_epsd_alone_has_lanes() {
    let mut off = Simulation::new(ball(None, 0.05, 0.2));
    let mut zero = Simulation::new(ball(cdt(0.0), 0.05, 0.2));
    assert!(!zero.plan().has(Stage::RollingResistance));
    run(&mut off, 500);
    run(&mut zero, 500);
    assert_eq!(off.model.particles.pos, zero.model.particles.pos);
    assert_eq!(off.model.particles.vel, zero.model.particles.vel);
    assert!(off.model.contacts.rolling.is_empty() && off.model.wall_rolling.is_empty());

    let mut c = Simulation::new(ball(cdt(0.1), 0.0, 0.2));
    run(&mut c, 10);
    assert!(c.model.contacts.rolling.is_empty() && c.model.wall_rolling.is_empty(), "cdt keeps no lanes");
    let sets: Vec<&str> = c.plan().lane_sets().iter().map(|s| s.stage).collect();
    assert_eq!(sets, ["core", "rotation", "heat_ledger"]);

    let mut e = Simulation::new(ball(epsd(0.1, 0.0), 0.0, 0.2));
    run(&mut e, 10);
    let plan = e.plan().clone();
    let text = plan.to_string();
    assert!(text.contains("rolling_resistance → integrate") && text.contains("rolling resistance(epsd, μ_r 0.1"));
    assert!(text.contains("rolling_resistance 24 B + 24 B per row entry (rolling_spring, wall_rolling_spring)"));
    assert_eq!(plan.row_entry_bytes(), 24);
    assert_eq!(e.model.wall_rolling.len(), 1, "one particle, one wall");
    assert_eq!(e.model.contacts.rolling.len(), e.model.contacts.other.len());
    assert!(e.model.wall_rolling[0].norm() > 0.0, "the wall spring carries the rolling torque");
}

#[cfg(feature = "gpu")]
mod gpu {
    use super::*;
    use crate::common::gpu;
    use matdem_engine::backend::gpu::device::GpuContext;

    // The GPU's cdt rolls the sphere to rest as the CPU's does (f32: within 1 %, and within 1 % of
    // the closed form).
    #[test]
    fn gpu_cdt_rolls_to_rest_as_the_cpu() {
        let Some(ctx) = gpu("gpu_cdt_roll") else { return };
        let (mu_r, v0) = (0.1, 0.2);
        let a = 5.0 / 7.0 * mu_r * G;
        let cpu = roll_to_rest(Simulation::new(ball(cdt(mu_r), 0.0, v0)), v0, 1.5 * v0 / a);
        let gpu = roll_to_rest(Simulation::with_gpu(ball(cdt(mu_r), 0.0, v0), ctx), v0, 1.5 * v0 / a);
        eprintln!(
            "stop: cpu {:.5} s {:.6} m; gpu {:.5} s {:.6} m; analytic {:.5} s {:.6} m",
            cpu.time,
            cpu.distance,
            gpu.time,
            gpu.distance,
            v0 / a,
            v0 * v0 / (2.0 * a)
        );
        assert!(rel(gpu.distance, cpu.distance) < 0.01 && rel(gpu.time, cpu.time) < 0.01);
        assert!(rel(gpu.distance, v0 * v0 / (2.0 * a)) < 0.01);
        // The device books the torque's work into its ledger as the CPU does.
        eprintln!("heat booked: cpu {:.6e} J, gpu {:.6e} J", cpu.heat, gpu.heat);
        assert!(rel(gpu.heat, cpu.heat) < 0.01, "heat booked on the device");
    }

    /// A 3 × 3 × 2 block of touching spheres on the floor, spun and shoved, with `rolling`.
    fn pile(rolling: Option<RollingResistance>) -> Model {
        let mut mat = material("grain", 2650.0, 1e5, 1e9, 0.2);
        mat.ks = 5e4;
        mat.mu_p = 0.5;
        let mut m = Model::new();
        let k = m.add_material(mat).unwrap();
        m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
        let s = 1.999 * R;
        for x in matdem_engine::builder::simple_cubic(3, 3, 2, s, Vec3::repeat(0.5 * s)) {
            m.add_particle(x, R, k).unwrap();
        }
        m.settings.gravity = Vec3::new(0.0, 0.0, -G);
        m.settings.rotation = true;
        m.particles.enable_rotation();
        let n = m.len();
        for i in 0..n {
            m.particles.vel[i] = Vec3::new(0.02 * ((i * 7) % 5) as f64, -0.01 * ((i * 3) % 4) as f64, 0.0);
            m.particles.rotation.as_mut().unwrap().ang_vel[i] =
                Vec3::new(3.0 * ((i % 3) as f64 - 1.0), 2.0 * ((i * 5 % 4) as f64 - 1.5), 1.0);
        }
        m.settings.rolling = rolling;
        m.set_standard_dt().unwrap();
        m
    }

    /// What physics fixes about the pile after `steps`, whatever the rounding of the device's
    /// compiler: its rotational kinetic energy (J) and the heat the contacts booked (J).
    fn pile_outcome(mut sim: Simulation, steps: u64) -> (f64, f64) {
        run(&mut sim, steps);
        let p = &sim.model.particles;
        let w = &p.rotation.as_ref().unwrap().ang_vel;
        let rotational = (0..p.len()).map(|i| 0.5 * 0.4 * p.mass[i] * p.radius[i].powi(2) * w[i].norm_squared()).sum();
        let e = sim.energies();
        (rotational, e.heat_friction + e.heat_damping + e.heat_contact_damping)
    }

    /// The pile on both backends, 400 steps, compared on what physics fixes. Its spins are
    /// not compared one by one: a grain at the edge of slip goes either way on a rounding, and
    /// NVIDIA's compiler (fused multiply-adds) rounds otherwise than lavapipe — on an H200 the
    /// spins differed by 4.7e-3 (cdt) and 1.1e-2 (epsd) of the largest (2026-12-04), where
    /// lavapipe's stay within 1e-3. The pile's rotational energy and the heat booked agree
    /// within 2 %, and rolling resistance changes the rotational energy by far more than that.
    fn pile_matches_the_cpu(rolling: Option<RollingResistance>, ctx: std::sync::Arc<GpuContext>, label: &str) {
        let (cpu_rot, cpu_heat) = pile_outcome(Simulation::new(pile(rolling)), 400);
        let (gpu_rot, gpu_heat) = pile_outcome(Simulation::with_gpu(pile(rolling), ctx), 400);
        let (free_rot, _) = pile_outcome(Simulation::new(pile(None)), 400);
        eprintln!(
            "{label} pile: rotational energy cpu {cpu_rot:.6e} J, gpu {gpu_rot:.6e} J, without rolling resistance \
             {free_rot:.6e} J; heat cpu {cpu_heat:.6e} J, gpu {gpu_heat:.6e} J"
        );
        assert!(rel(gpu_rot, cpu_rot) < 0.02, "rotational energy: cpu {cpu_rot:e}, gpu {gpu_rot:e}");
        assert!(rel(gpu_heat, cpu_heat) < 0.02, "heat booked: cpu {cpu_heat:e}, gpu {gpu_heat:e}");
        assert!(rel(free_rot, cpu_rot) > 0.2, "rolling resistance must change the pile: {free_rot:e} vs {cpu_rot:e}");
    }

    #[test]
    fn gpu_cdt_matches_the_cpu_on_a_pile() {
        let Some(ctx) = gpu("gpu_cdt_pile") else { return };
        pile_matches_the_cpu(cdt(0.3), ctx, "cdt");
    }

    // epsd on the GPU: the slope test's answers (the sphere held below θ_c, rolling away above
    // at the closed-form rate), with its wall spring kept on the device.
    #[test]
    fn gpu_epsd_holds_and_rolls_as_the_closed_form() {
        let Some(ctx) = gpu("gpu_epsd_slope") else { return };
        check_slope(|m| Simulation::with_gpu(m, ctx.clone()));
    }

    // epsd on the pile: as cdt's.
    #[test]
    fn gpu_epsd_matches_the_cpu_on_a_pile() {
        let Some(ctx) = gpu("gpu_epsd_pile") else { return };
        pile_matches_the_cpu(epsd(0.3, 0.3), ctx, "epsd");
    }

    // The device's row build carries each pair's rolling spring to its new slot, as the host's
    // rebuild does: springs wound on the CPU come back from an upload, a device build and a
    // download unchanged (to f32).
    #[test]
    fn gpu_row_builds_carry_the_rolling_springs() {
        use matdem_engine::backend::gpu::GpuBackend;
        let Some(ctx) = gpu("gpu_epsd_rows") else { return };
        let mut sim = Simulation::new(pile(epsd(0.3, 0.0)));
        run(&mut sim, 3);
        let mut m = sim.model;
        let springs = |m: &Model| {
            let c = &m.contacts;
            let mut v: Vec<(usize, u32, Vec3)> = Vec::new();
            for i in 0..m.len() {
                for e in c.row(i) {
                    v.push((i, c.other[e], c.rolling[e]));
                }
            }
            v
        };
        let before = springs(&m);
        let wound = before.iter().filter(|s| s.2.norm() > 0.0).count();
        eprintln!("{wound} of {} row entries carry a rolling spring", before.len());
        assert!(wound >= 8, "springs wound");
        let mut b = GpuBackend::prepare(ctx, &m).unwrap();
        b.build_rows_once(&mut m).unwrap().expect("the rows fit their slots");
        let after = springs(&m);
        assert_eq!(before.len(), after.len());
        for (a, b) in before.iter().zip(&after) {
            assert_eq!((a.0, a.1), (b.0, b.1));
            assert!((a.2 - b.2).norm() <= 1e-6 * a.2.norm() + 1e-30, "{a:?} {b:?}");
        }
    }
}
