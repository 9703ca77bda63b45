//! Pore flow coupled into the time step (the `pore_flow` stage): Terzaghi's 1-D consolidation
//! of a saturated column under a step load, mass conservation through the coupled loop while
//! the grains move (and the network is rebuilt), the permeability of a random packing against
//! Kozeny–Carman, the plan's words, and the guard's refusal of an unstable flow.

use crate::common::pore_column;
use matdem_engine::backend::RunControl;
use matdem_engine::builder::{BoxSpec, Container, SizeClass};
use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, PoreRegion};
use matdem_engine::error::Side;
use matdem_engine::physics::Vec3;
use matdem_engine::plan::{Stage, StepPlan};
use matdem_engine::{Error, Material, Model, Simulation, WallMotion};
use std::f64::consts::PI;

const A: f64 = 1e-3;
const KN: f64 = 1e6;

fn column(nx: usize, nz: usize) -> Model {
    pore_column(nx, nz, A, KN)
}

pub(crate) fn top_layer(nx: usize, nz: usize) -> Vec<u32> {
    (((nz - 1) * nx * nx) as u32..(nz * nx * nx) as u32).collect()
}

/// Mean z displacement of the top layer since the start (positive down).
pub(crate) fn settlement(m: &Model, nx: usize, nz: usize) -> f64 {
    let h = (nz - 1) as f64 * A;
    let top = top_layer(nx, nz);
    top.iter().map(|&i| h - m.particles.pos[i as usize].z).sum::<f64>() / top.len() as f64
}

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

/// Terzaghi's excess pore pressure, u/u0 at depth z below the drained face of a layer of
/// drainage length H at time factor T_v.
pub(crate) fn terzaghi(z_over_h: f64, tv: f64) -> f64 {
    (0..200)
        .map(|m| {
            let mm = (2 * m + 1) as f64 * PI / 2.0;
            2.0 / mm * (mm * z_over_h).sin() * (-mm * mm * tv).exp()
        })
        .sum()
}

/// Average degree of consolidation U(T_v).
fn degree(tv: f64) -> f64 {
    1.0 - (0..200)
        .map(|m| {
            let mm = (2 * m + 1) as f64 * PI / 2.0;
            2.0 / (mm * mm) * (-mm * mm * tv).exp()
        })
        .sum::<f64>()
}

/// The volume-weighted mean pore pressure of the pores whose centres lie in each cell layer
/// k (between element layers k and k + 1).
pub(crate) fn layer_pressures(m: &Model, nz: usize) -> Vec<f64> {
    let f = m.pores.as_ref().unwrap();
    let net = &f.network;
    let mut pv = vec![0.0; nz - 1];
    let mut v = vec![0.0; nz - 1];
    for p in 0..net.pore_count() {
        let k = ((net.centre[p].z / A).floor().max(0.0) as usize).min(nz - 2);
        pv[k] += f.pressure[p] * net.volume[p];
        v[k] += net.volume[p];
    }
    pv.iter().zip(&v).map(|(a, b)| a / b).collect()
}

#[test]
fn terzaghi_consolidation_of_a_saturated_column_under_a_step_load() {
    let (nx, nz) = (3, 12);
    let sigma = 1e6;
    let hull = ((nx - 1) as f64 * A).powi(2);

    // 1. The skeleton's constrained modulus, measured: the dry column under the same load
    //    through the servo-controlled top wall, balanced; M = σ / ε, ε = settlement / height.
    let mut dry = Simulation::new(column(nx, nz));
    let dt = dry.model.clock.dt;
    dry.model.wall_mut("top").unwrap().motion = WallMotion::Servo { stress: sigma, max_speed: 1e-3 * A / dt };
    run(&mut dry, 20_000);
    let height = (nz - 1) as f64 * A;
    let s_final = settlement(&dry.model, nx, nz);
    let modulus = sigma / (s_final / height);
    let _ = hull;
    println!(
        "constrained modulus (measured, dry) M = {modulus:.4e} Pa; the lattice's kn/a = {:.4e} Pa; wall stress {:.4e} Pa",
        KN / A,
        dry.model.wall_mut("top").unwrap().stress()
    );

    // 2. The saturated column: pore flow on, drained through the pores the top layer bounds,
    //    sealed elsewhere (bottom and sides impermeable).
    let mut m = column(nx, nz);
    let k_f = 10.0 * modulus;
    m.settings.pores.fluid = Fluid { bulk_modulus: k_f, viscosity: 1.0, max_substeps: 200, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    m.add_pore_boundary(PoreRegion::Elements(top_layer(nx, nz)), BoundaryKind::Pressure(0.0)).unwrap();
    // The network's permeability, measured on the column itself: steady Darcy flow from the
    // pores the bottom layer bounds (1 Pa) to those the top layer bounds (0), everything else
    // sealed; k = μ·Q·L/(A·Δp), L between the two reservoirs' mean pore centres, A the hull's
    // cross-section.
    let f = m.pores.as_ref().unwrap();
    let bottom: Vec<u32> = (0..(nx * nx) as u32).collect();
    let (q, c_in, c_out) = f.darcy_flux(PoreRegion::Elements(bottom), PoreRegion::Elements(top_layer(nx, nz))).unwrap();
    let k = f.fluid.viscosity * q * (c_out.z - c_in.z) / hull;
    let n = f.porosity(&m.particles.pos);
    // Drainage length: from the drained pores' centres (the top cell layer, z = (nz − 1.5)·a)
    // to the sealed bottom (the hull, z = 0).
    let h_drain = (nz as f64 - 1.5) * A;
    // c_v = k / (μ·(1/M + n/K_f)): Biot's 1-D consolidation with a compressible fluid and
    // incompressible grains; the fluid share of the load at t = 0 is u0/σ = 1/(1 + n·M/K_f).
    // μ chosen so that T_v = 1 after 20,000 steps.
    let storage = 1.0 / modulus + n / k_f;
    let t_end = 20_000.0 * dt;
    let mu = k * t_end / (storage * h_drain * h_drain);
    m.set_pore_fluid(Fluid { viscosity: mu, ..m.settings.pores.fluid.clone() }).unwrap();
    let cv = k / (mu * storage);
    let u0 = sigma / (1.0 + n * modulus / k_f);
    println!(
        "k = {k:.4e} m² ({:.4e} a², reservoirs {:.3} a apart), porosity {n:.4}, μ = {mu:.4e} Pa·s, c_v = {cv:.4e} \
         m²/s, H = {h_drain:.3e} m, u0 = {u0:.4e} Pa",
        k / (A * A),
        (c_out.z - c_in.z) / A
    );

    let mut sim = Simulation::new(m);
    println!("{}", sim.plan());
    sim.model.wall_mut("top").unwrap().motion = WallMotion::Servo { stress: sigma, max_speed: 1e-3 * A / dt };
    // Mid-depth z = H/2 below the drained face: between cell layers, interpolated.
    let z_mid = (nz as f64 - 1.5) * A - 0.5 * h_drain;
    let mid = |m: &Model| {
        let p = layer_pressures(m, nz);
        let x = z_mid / A - 0.5;
        let (k, w) = (x.floor() as usize, x - x.floor());
        p[k] * (1.0 - w) + p[k + 1] * w
    };
    let checks = [0.1, 0.3, 0.6];
    let mut done = 0u64;
    let mut last_s = 0.0;
    let mut rows = Vec::new();
    for &tv in &checks {
        let steps = (tv * t_end / dt).round() as u64;
        // Settlement monotonic: sampled every 500 steps on the way.
        while done < steps {
            let chunk = (steps - done).min(500);
            run(&mut sim, chunk);
            done += chunk;
            let s = settlement(&sim.model, nx, nz);
            if done > 2000 {
                assert!(s >= last_s - 1e-6 * s_final, "settlement went back from {last_s:e} to {s:e} at step {done}");
            }
            last_s = s;
        }
        let t = sim.model.clock.time;
        let tv_now = cv * t / (h_drain * h_drain);
        let u = mid(&sim.model) / u0;
        let want = terzaghi(0.5, tv_now);
        let s = settlement(&sim.model, nx, nz);
        rows.push((tv_now, u, want, s / s_final, degree(tv_now)));
        println!(
            "T_v = {tv_now:.3}: u/u0 at mid-depth {u:.4} vs Terzaghi {want:.4} ({:+.1} %); settlement {:.4} of the \
             drained; U(T_v) = {:.4}",
            (u / want - 1.0) * 100.0,
            s / s_final,
            degree(tv_now)
        );
    }
    for (tv, u, want, _, _) in &rows {
        assert!((u / want - 1.0).abs() < 0.10, "T_v = {tv:.3}: u/u0 = {u:.4} vs Terzaghi's {want:.4}");
    }
    // The settlement follows the degree of consolidation U(T_v) (within 5 % of the final
    // value after the first check, where the drained top cell's own compression leads it).
    for (tv, _, _, s, u) in &rows[1..] {
        assert!((s - u).abs() < 0.05, "settlement {s:.4} of the drained at T_v = {tv:.3}, U = {u:.4}");
    }
    // Run on to T_v = 2: the settlement reaches the drained value (U = 0.994).
    let steps = (2.0 * t_end / dt) as u64 - done;
    run(&mut sim, steps);
    let s_end = settlement(&sim.model, nx, nz) / s_final;
    println!("T_v = 2: settlement {s_end:.4} of the drained; U(2) = {:.4}", degree(2.0));
    assert!((s_end - degree(2.0)).abs() < 0.02, "settlement {s_end} of the drained at T_v = 2");
}

/// A column whose top wall compresses it (the grains move; the network follows and is
/// rebuilt often), the fluid sealed in: its mass is conserved to round-off.
#[test]
fn mass_is_conserved_to_round_off_through_the_coupled_loop_while_the_grains_move() {
    let (nx, nz) = (3, 6);
    let mut m = column(nx, nz);
    m.settings.pores.fluid =
        Fluid { bulk_modulus: 1e8, viscosity: 1e-2, max_substeps: 10_000, rebuild_drift: 2e-4, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    let dt = m.clock.dt;
    let m0 = m.pores.as_ref().unwrap().total_mass();
    let mut sim = Simulation::new(m);
    sim.model.wall_mut("top").unwrap().motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -2e-4 * A / (1000.0 * dt)));
    run(&mut sim, 3000);
    let f = sim.model.pores.as_ref().unwrap();
    let drift = (f.total_mass() - m0).abs() / m0;
    let pmax = f.pressure.iter().fold(0.0f64, |a, &p| a.max(p));
    println!(
        "mass drift {drift:.2e} of itself after 3000 coupled steps, {} rebuilds, settlement {:.3e} m, max pressure \
         {pmax:.3e} Pa",
        f.rebuilds,
        settlement(&sim.model, nx, nz)
    );
    assert!(f.rebuilds > 0, "the network was never rebuilt");
    assert!(pmax > 0.0, "the compression raised no pressure");
    assert!(f.boundary_mass.abs() < 1e-12 * m0, "the sealed boundaries added {:e} kg", f.boundary_mass);
    assert!(drift < 1e-12, "mass changed by {drift:e} of itself");
}

/// A random packing (random sequential addition, deposited under gravity and compacted by a
/// servo platen) against Kozeny–Carman, k = d²·n³ / (180·(1 − n)²), d the Sauter mean
/// diameter Σd³/Σd², n the network's porosity.
#[test]
fn permeability_of_a_random_packing_is_kozeny_carmans_within_a_factor_of_two() {
    let mut m = Model::new();
    m.add_material(Material::from_micro("grain", 2650.0, 2e4, 8e3, 0.0, 0.0, 0.1, 0.5e-3).unwrap()).unwrap();
    let spec = BoxSpec {
        container: Container::Cuboid { width: 6e-3, length: 6e-3 },
        height: 7e-3,
        classes: vec![SizeClass { r_min: 0.4e-3, r_max: 0.55e-3, mass_ratio: 1.0 }],
        target_porosity: 0.4,
        seed: 11,
        top_platen: true,
    };
    spec.build_into(&mut m).unwrap();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81 * 1000.0);
    m.settings.local_damping = 0.3;
    m.set_standard_dt().unwrap();
    let mut sim = Simulation::new(m);
    run(&mut sim, 8000);
    let dt = sim.model.clock.dt;
    sim.model.wall_mut("top_platen").unwrap().motion = WallMotion::Servo { stress: 2e3, max_speed: 2e-3 * 0.5e-3 / dt };
    run(&mut sim, 4000);
    let mut m = sim.model;
    m.enable_pore_flow().unwrap();
    let f = m.pores.as_ref().unwrap();
    let r = &m.particles.radius;
    let d32 = 2.0 * r.iter().map(|x| x.powi(3)).sum::<f64>() / r.iter().map(|x| x * x).sum::<f64>();
    for axis in [0, 2] {
        let perm = f.permeability(&m.particles.pos, axis).unwrap();
        let n = perm.porosity;
        let kc = d32 * d32 * n.powi(3) / (180.0 * (1.0 - n).powi(2));
        let ratio = perm.k / kc;
        println!(
            "{} elements, {} pores: axis {axis}: k = {:.4e} m², porosity {n:.4}, d32 = {d32:.4e} m, Kozeny–Carman \
             {kc:.4e} m², ratio {ratio:.3}",
            m.len(),
            f.network.pore_count(),
            perm.k
        );
        assert!((0.5..2.0).contains(&ratio), "axis {axis}: k / k_KC = {ratio:.3}");
    }
}

#[test]
fn the_plan_lists_the_stage_only_when_the_scene_enables_it() {
    let mut m = column(3, 4);
    let plan = StepPlan::build(&m);
    assert!(!plan.has(Stage::PoreFlow));
    assert!(plan.to_string().contains("fluid flow"), "{plan}");
    assert!(m.pores.is_none());
    m.enable_pore_flow().unwrap();
    let plan = StepPlan::build(&m);
    assert!(plan.has(Stage::PoreFlow));
    let s = plan.to_string();
    assert!(s.contains("stages: walls → neighbours → contact_forces → wall_forces → pore_flow → integrate"), "{s}");
    assert!(s.contains("pore_flow(") && s.contains("pore network"), "{s}");
    m.disable_pore_flow();
    assert!(!StepPlan::build(&m).has(Stage::PoreFlow));
    assert!(m.pores.is_none());
}

#[test]
fn an_unstable_flow_stops_the_run_naming_the_pore_and_the_critical_step() {
    let mut m = column(3, 4);
    m.settings.pores.fluid = Fluid { bulk_modulus: 2.2e9, viscosity: 1e-3, max_substeps: 5, ..Fluid::default() };
    m.enable_pore_flow().unwrap();
    let (pore, crit) = m.pores.as_ref().unwrap().critical_dt();
    let mut sim = Simulation::new(m);
    let e = sim.run(10, &RunControl::default(), &mut |_| {}).unwrap_err();
    let Error::Unstable(i) = &e else { panic!("expected the guard's error, got {e}") };
    assert_eq!(i.critical_dt, crit);
    let s = e.to_string();
    assert!(s.contains(&format!("pore {pore}")) && s.contains("max_substeps"), "{s}");
    assert!(sim.model.particles.pos.iter().all(|x| x.iter().all(|v| v.is_finite())));
    assert!(sim.model.pores.as_ref().unwrap().pressure.iter().all(|p| p.is_finite()));
    assert_eq!(sim.model.clock.step, 1, "the run stops after the step that found it");
}

/// The K_f a message suggests ("soften it below K_f = … Pa").
fn suggested_bulk_modulus(message: &str) -> f64 {
    let tail = message.split("soften it below K_f = ").nth(1).unwrap_or_else(|| panic!("no suggestion: {message}"));
    tail.split(' ').next().unwrap().parse().unwrap()
}

// A fluid too stiff for the pores it fills is a spring on the grains that the contacts' time
// step cannot integrate: the run blows up, and the guard's message names the fluid (the pore,
// its spring against the contacts', the critical step with it) and a bulk modulus to soften it
// to — with which the same scene runs to the end.
#[test]
fn a_fluid_too_stiff_for_its_pores_is_named_with_the_bulk_modulus_that_runs() {
    let scene = |k_f: f64| {
        let mut m = column(3, 4);
        // Viscous enough that the flow needs few sub-steps: the mechanical step is what fails.
        m.settings.pores.fluid = Fluid { bulk_modulus: k_f, viscosity: 1e3, max_substeps: 1000, ..Fluid::default() };
        m.enable_pore_flow().unwrap();
        m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
        Simulation::new(m)
    };
    let mut stiff = scene(1e13);
    let e = stiff.run(3000, &RunControl::default(), &mut |_| {}).unwrap_err();
    let s = e.to_string();
    assert!(s.contains("whose fluid (K_f = 1.000e13 Pa) pushes back like a spring"), "{s}");
    let Error::Unstable(i) = &e else { panic!("expected the guard's error, got {e}") };
    assert!(i.critical_dt < i.dt, "{s}");
    let k_f = suggested_bulk_modulus(&s);
    assert!(k_f > 0.0 && k_f < 1e13, "{s}");
    // The same numbers ride on the error for a host to check against what its user may set.
    let named = |p: &str| i.suggest.iter().find(|x| x.parameter == p && x.side == Side::Below).map(|x| x.bound);
    let k_bound = named("bulk_modulus").unwrap_or_else(|| panic!("no bulk_modulus in {:?}", i.suggest));
    assert!((k_bound - k_f).abs() <= 1e-3 * k_f, "{k_bound:e} against the message's {k_f:e}");
    assert_eq!(named("dt"), Some(i.critical_dt));
    let mut soft = scene(0.5 * k_f);
    soft.run(3000, &RunControl::default(), &mut |_| {}).unwrap();
    assert!(soft.model.particles.vel.iter().all(|v| v.norm().is_finite()));
    // Softening the fluid of a model already stepped drops the stiff estimate with it.
    let mut m = scene(1e13).model;
    let mut sim = Simulation::new({
        m.settings.gravity = Vec3::zeros();
        m
    });
    sim.run(1, &RunControl::default(), &mut |_| {}).unwrap();
    assert!(sim.model.pores.as_ref().unwrap().stiffest.is_some());
    let fluid = Fluid { bulk_modulus: 0.5 * k_f, ..sim.model.settings.pores.fluid.clone() };
    sim.model.set_pore_fluid(fluid).unwrap();
    assert!(sim.model.pores.as_ref().unwrap().stiffest.is_none(), "a stale estimate would blame the new fluid");
}
