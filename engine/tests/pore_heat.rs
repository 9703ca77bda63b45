//! Heat in the pore fluid (docs/pore-flow.md, "Temperature"): the thermal energy of grains and
//! fluid conserved to round-off with insulated, impermeable boundaries while the fluid flows,
//! the grains move and the network is rebuilt; the regions' booked heat closing the account
//! when hot fluid is injected and drained; thermal pressurisation of a sealed rigid sample,
//! Δp = K_f·β_f·ΔT; a temperature front carried through a column at the seepage velocity.

use crate::common::confine_column;
use matdem_engine::backend::RunControl;
use matdem_engine::effects::conduction::{ThermalMode, ThermalProps};
use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, FluidHeat, PoreBoundary, PoreFlow, PoreRegion};
use matdem_engine::physics::Vec3;
use matdem_engine::plan::StepPlan;
use matdem_engine::state::particles::dof;
use matdem_engine::{Material, Model, Simulation, WallMotion};

pub(crate) const A: f64 = 1e-3;
pub(crate) const T0: f64 = 293.15;

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

/// Σ C_i·(T_i − T0) over the elements plus Σ c_f·m_p·(T_p − T0) over the pores (J).
pub(crate) fn thermal_energy(m: &Model) -> (f64, f64) {
    let th = &m.particles.thermal;
    let grains: f64 = th.capacity.iter().zip(&th.temperature).map(|(c, t)| c * (t - T0)).sum();
    (grains, m.pores.as_ref().unwrap().fluid_heat())
}

/// A simple-cubic column (nx × nx × nz) of bonded, touching spheres (r = a/2), its bottom layer
/// held and the rest confined laterally, under a top wall; heat on with element properties
/// scaled down (c = 0.8 J/(kg·K)) so that grains and fluid exchange within a few thousand steps.
pub(crate) fn bonded_column(nx: usize, nz: usize) -> Model {
    let mut m = Model::new();
    let mat =
        m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 1e-3, 1e9, 0.5, 0.5 * A).unwrap()).unwrap();
    for k in 0..nz {
        for j in 0..nx {
            for i in 0..nx {
                m.add_particle(Vec3::new(i as f64, j as f64, k as f64) * A, 0.5 * A, mat).unwrap();
            }
        }
    }
    confine_column(&mut m, nx, nz, A);
    m.enable_heat();
    m.set_thermal_material("grain", ThermalProps { conductivity: 3.0, specific_heat: 0.8, expansion: 0.0 }).unwrap();
    m
}

/// A soft fluid with a small heat capacity (so it exchanges with the grains within the test).
pub(crate) fn warm_fluid() -> Fluid {
    Fluid {
        bulk_modulus: 1e8,
        viscosity: 1e-2,
        max_substeps: 10_000,
        rebuild_drift: 2e-4,
        heat: FluidHeat { specific_heat: 4.186, ..FluidHeat::default() },
        ..Fluid::default()
    }
}

/// Grains at uneven temperatures, the fluid at others, sealed in and compressed by the top wall
/// (so the fluid flows and the network is rebuilt): Σ C·(T − T0) of grains and fluid together
/// is conserved to round-off, while heat moves between them.
#[test]
fn thermal_energy_of_grains_and_fluid_is_conserved_to_round_off_with_insulated_sealed_boundaries() {
    let (nx, nz) = (3, 6);
    let mut m = bonded_column(nx, nz);
    m.settings.pores.fluid = warm_fluid();
    m.enable_pore_flow().unwrap();
    for (i, t) in m.particles.thermal.temperature.iter_mut().enumerate() {
        *t = T0 + 40.0 * ((i * 7) % 5) as f64;
    }
    let dt = m.clock.dt;
    let mut sim = Simulation::new(m);
    run(&mut sim, 1);
    {
        // The fluid starts hotter in every third pore.
        let f = sim.model.pores.as_mut().unwrap();
        for p in (0..f.temperature.len()).step_by(3) {
            f.temperature[p] += 80.0;
        }
    }
    let (g0, f0) = thermal_energy(&sim.model);
    let scale = {
        let th = &sim.model.particles.thermal;
        let f = sim.model.pores.as_ref().unwrap();
        th.capacity.iter().zip(&th.temperature).map(|(c, t)| c * (t - T0).abs()).sum::<f64>()
            + (0..f.mass.len()).map(|p| 4.186 * f.mass[p] * (f.temperature[p] - T0).abs()).sum::<f64>()
    };
    sim.model.wall_mut("top").unwrap().motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -2e-4 * A / (1000.0 * dt)));
    run(&mut sim, 1500);
    let (g1, f1) = thermal_energy(&sim.model);
    let f = sim.model.pores.as_ref().unwrap();
    let drift = ((g1 + f1) - (g0 + f0)).abs() / scale;
    println!(
        "grains {g0:.6e} → {g1:.6e} J, fluid {f0:.6e} → {f1:.6e} J, change of the sum {drift:.2e} of Σ|C·(T − T0)|; \
         {} rebuilds, exchange in {} sub-step(s)",
        f.rebuilds, f.exchange_substeps
    );
    assert!(f.rebuilds > 0, "the network was never rebuilt");
    assert!((f1 - f0).abs() > 0.05 * f0.abs(), "the fluid exchanged almost no heat ({f0:e} → {f1:e} J)");
    assert!(f.pressure.iter().any(|&p| p.abs() > 1.0), "nothing drove the fluid");
    assert!(drift < 1e-12, "thermal energy changed by {drift:e} of its scale");
}

/// A simple-cubic block (n³, r = 0.4 a: no contacts), every element held in place.
pub(crate) fn rigid_block(n: usize) -> Model {
    let mut m = Model::new();
    let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4 * A).unwrap()).unwrap();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                m.add_particle(Vec3::new(i as f64, j as f64, k as f64) * A, 0.4 * A, mat).unwrap();
            }
        }
    }
    let all: Vec<u32> = (0..m.len() as u32).collect();
    m.fix(&all, dof::ALL, true).unwrap();
    m.groups.set("all", all);
    m.set_dt(5e-7).unwrap();
    m.enable_heat();
    m.set_thermal_material("grain", ThermalProps { conductivity: 3.0, specific_heat: 0.8, expansion: 0.0 }).unwrap();
    m
}

/// Undrained thermal pressurisation: a sealed sample on a rigid skeleton whose grains are held
/// ΔT above T0; the fluid takes their temperature and its pressure rises by K_f·β_f·ΔT
/// (exact for a rigid skeleton), its mass unchanged.
#[test]
fn a_sealed_rigid_sample_heated_by_dt_raises_its_pore_pressure_by_bulk_modulus_times_expansion_times_dt() {
    let dtemp = 30.0;
    let mut m = rigid_block(5);
    // A soft fluid with a tiny heat capacity, so that it takes the grains' temperature within
    // the test; the end state does not depend on either.
    let heat = FluidHeat { specific_heat: 0.004186, ..FluidHeat::default() };
    m.settings.pores.fluid = Fluid { bulk_modulus: 1e6, viscosity: 1.0, heat, ..warm_fluid() };
    m.enable_pore_flow().unwrap();
    m.set_thermal_mode("all", ThermalMode::Fixed(Some(T0 + dtemp))).unwrap();
    let m0 = m.pores.as_ref().unwrap().total_mass();
    let mut sim = Simulation::new(m);
    run(&mut sim, 600);
    let f = sim.model.pores.as_ref().unwrap();
    let want = f.fluid.bulk_modulus * f.fluid.heat.expansion * dtemp;
    let worst = f.pressure.iter().map(|p| (p / want - 1.0).abs()).fold(0.0, f64::max);
    let coolest = f.temperature.iter().fold(f64::MAX, |a, &t| a.min(t));
    println!(
        "K_f·β_f·ΔT = {want:.6e} Pa; pore pressures within {worst:.2e} of it; coolest pore {:.9} K above T0; {} pores",
        coolest - T0,
        f.temperature.len()
    );
    println!("flow sub-steps {}, exchange sub-steps {}", f.substeps, f.exchange_substeps);
    assert!(worst < 1e-9, "a pore's pressure is {worst:e} off K_f·β_f·ΔT");
    assert!((f.total_mass() / m0 - 1.0).abs() < 1e-14, "the sealed sample's mass changed");
}

/// Hot fluid injected at one end of a rigid block and drained at the other: the heat the
/// grains and the fluid gain is exactly what the regions booked (injected minus drained).
#[test]
fn heat_injected_and_drained_through_the_boundaries_is_booked_to_round_off() {
    let mut m = rigid_block(5);
    m.settings.pores.fluid = Fluid { bulk_modulus: 1e6, viscosity: 0.1, ..warm_fluid() };
    m.enable_pore_flow().unwrap();
    let (big, rate) = (1.0, 1e-5);
    let hot = T0 + 50.0;
    let lo = PoreRegion::Box { lo: Vec3::repeat(-big), hi: Vec3::new(big, big, 0.6 * A) };
    let hi = PoreRegion::Box { lo: Vec3::new(-big, -big, 3.4 * A), hi: Vec3::repeat(big) };
    m.add_pore_boundary_at(lo, BoundaryKind::Flux(rate), Some(hot)).unwrap();
    m.add_pore_boundary(hi, BoundaryKind::Pressure(0.0)).unwrap();
    let mut sim = Simulation::new(m);
    run(&mut sim, 1);
    let (g0, f0) = thermal_energy(&sim.model);
    let b0: f64 = sim.model.pores.as_ref().unwrap().region_heat.iter().sum();
    run(&mut sim, 1500);
    let (g1, f1) = thermal_energy(&sim.model);
    let f = sim.model.pores.as_ref().unwrap();
    let booked: f64 = f.region_heat.iter().sum::<f64>() - b0;
    let gained = (g1 + f1) - (g0 + f0);
    let injected = f.region_heat[0];
    println!(
        "injected {injected:.6e} J, drained {:.6e} J, grains and fluid gained {gained:.6e} J (booked {booked:.6e}); \
         injected mass {:.4e} kg = ρ0·q·t {:.4e}",
        f.region_heat[1],
        f.region_mass[0],
        1000.0 * rate * sim.model.clock.time
    );
    assert!(g1 > g0 && injected > 0.0, "the injected heat did not reach the grains");
    // Round-off, accumulated: the regions' books and the pores' heat each take some 10⁵
    // nearly equal increments, whose rounding errors add up rather than cancel.
    assert!(((gained - booked) / injected).abs() < 1e-10, "gained {gained:e} J vs booked {booked:e} J");
    let mass_err = f.region_mass[0] / (1000.0 * rate * sim.model.clock.time) - 1.0;
    assert!(mass_err.abs() < 1e-10, "injected mass off ρ0·q·t by {mass_err:e}");
}

/// A column (3 × 3 × nz, r = 0.4 a) with steady flow between a hot reservoir below and a drain
/// above; the fluid does not exchange with the grains (Nu = 0), so the temperature front
/// moves at the seepage velocity: it reaches the height where the free pores below hold the
/// mass ρ0·Q·t that has come in (mass rather than volume: the pores near the inlet hold their
/// fluid compressed by p/K_f, up to 20 % here). The 50 % point of the layer-averaged profile is compared with
/// that height; the explicit upwind scheme smears the front (its 10–90 % width is printed).
#[test]
fn a_temperature_front_is_carried_through_a_column_at_the_seepage_velocity() {
    let (n, nz) = (3, 16);
    let mut m = Model::new();
    let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4 * A).unwrap()).unwrap();
    for i in 0..n {
        for j in 0..n {
            for k in 0..nz {
                m.add_particle(Vec3::new(i as f64, j as f64, k as f64) * A, 0.4 * A, mat).unwrap();
            }
        }
    }
    let fluid = Fluid {
        bulk_modulus: 1e6,
        max_substeps: 1_000_000,
        heat: FluidHeat { expansion: 0.0, nusselt: 0.0, ..FluidHeat::default() },
        ..Fluid::default()
    };
    let mut f = PoreFlow::new(&m, fluid).unwrap();
    let (big, top, hot, p_in) = (1.0, (nz - 1) as f64 * A, 50.0, 2e5);
    f.temperature = vec![T0; f.mass.len()];
    f.reference = T0;
    f.set_boundaries(vec![
        PoreBoundary::boxed(Vec3::repeat(-big), Vec3::new(big, big, 0.5 * A), BoundaryKind::Pressure(p_in))
            .at_temperature(T0 + hot),
        PoreBoundary::boxed(Vec3::new(-big, -big, top - 0.5 * A), Vec3::repeat(big), BoundaryKind::Pressure(0.0)),
    ])
    .unwrap();
    f.solve_steady(1e-13).unwrap();
    let q = f.boundary_flow[0];
    let (_, crit) = f.critical_dt();
    let h = 0.9 * crit;
    // Free pores by height, with their (steady) masses.
    let net = &f.network;
    let free: Vec<usize> = (0..net.pore_count()).filter(|&p| f.fixed_pressure(p).is_none()).collect();
    let mut by_z: Vec<(f64, f64)> = free.iter().map(|&p| (net.centre[p].z, f.mass[p])).collect();
    by_z.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The height below which the free pores hold the mass `v` (linear within a pore's share).
    let plug = |v: f64| {
        let mut acc = 0.0;
        for w in by_z.windows(2) {
            if acc + w[0].1 >= v {
                return w[0].0 + (w[1].0 - w[0].0) * (v - acc) / w[0].1;
            }
            acc += w[0].1;
        }
        f64::NAN
    };
    // Layer-averaged excess temperature over slabs of a/2, and where it crosses `level`.
    let profile = |f: &PoreFlow| {
        let slabs = 2 * nz;
        let (mut e, mut w) = (vec![0.0; slabs], vec![0.0; slabs]);
        for &p in &free {
            let s = ((f.network.centre[p].z / (0.5 * A)) as usize).min(slabs - 1);
            e[s] += f.network.volume[p] * (f.temperature[p] - T0) / hot;
            w[s] += f.network.volume[p];
        }
        (0..slabs).filter(|&s| w[s] > 0.0).map(|s| ((s as f64 + 0.5) * 0.5 * A, e[s] / w[s])).collect::<Vec<_>>()
    };
    let crossing = |prof: &[(f64, f64)], level: f64| {
        prof.windows(2)
            .find(|w| w[0].1 >= level && w[1].1 < level)
            .map(|w| w[0].0 + (w[1].0 - w[0].0) * (w[0].1 - level) / (w[0].1 - w[1].1))
            .unwrap_or(f64::NAN)
    };
    let total: f64 = by_z.iter().map(|x| x.1).sum();
    let rho0 = f.fluid.density;
    let mut t = 0.0;
    for target in [0.3, 0.5] {
        while rho0 * q * t < target * total {
            f.substep(h);
            t += h;
        }
        let prof = profile(&f);
        let (front, want) = (crossing(&prof, 0.5), plug(rho0 * q * t));
        let width = crossing(&prof, 0.1) - crossing(&prof, 0.9);
        println!(
            "after {:.3e} s ({:.0} % of the fluid mass in): front at {:.3} a, plug flow {:.3} a, 10–90 % width {:.2} a",
            t,
            100.0 * rho0 * q * t / total,
            front / A,
            want / A,
            width / A
        );
        assert!((front - want).abs() < 0.5 * A, "front at {front:e} m vs plug flow at {want:e} m");
    }
}

/// The plan names the fluid's temperature only when heat and pore flow are both on.
#[test]
fn the_plan_lists_the_fluid_temperature_only_with_heat_on() {
    let mut m = rigid_block(3);
    m.settings.heat.enabled = false;
    m.enable_pore_flow().unwrap();
    let words = StepPlan::build(&m).to_string();
    assert!(words.contains("pore_flow(") && !words.contains("fluid temperature"), "{words}");
    m.enable_heat();
    let words = StepPlan::build(&m).to_string();
    assert!(words.contains("fluid temperature: in the equation of state"), "{words}");
    assert!(words.contains("temperature"), "{words}");
}
