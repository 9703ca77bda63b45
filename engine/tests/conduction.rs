//! Heat conduction (the `conduction` stage) against exact answers (reference/physics.md §4):
//! a 1-D chain's steady profile and its transient (the series solution with a small step,
//! forward Euler's own discrete form at a large one), conservation of Σ C·T with insulated
//! boundaries, an FCC block's effective conductivity 2√2·H/d, the stability guard, and
//! thermal expansion of a free element, a bonded bar and a clamped bar (σ = E·α·ΔT).

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::effects::conduction::physics::pair_conductance;
use matdem_engine::effects::conduction::{ThermalMode, ThermalProps};
use matdem_engine::state::particles::dof;
use matdem_engine::{Error, Model, NormalKind, Simulation, Vec3, Wall};
use std::f64::consts::PI;

/// Chain nodes 0…N.
const N: usize = 10;
const R: f64 = 0.5;
/// Conductivity: a bond's neck is 0.5·R, so H = 4·(R/2)·k/2 = k·R.
const K: f64 = 2.0;

/// N + 1 bonded, touching elements on the x axis, held in place (conduction only), heat on,
/// T0 = 0, every capacity C = H/λ.
fn chain(lambda: f64, dt: f64) -> (Model, f64) {
    let mut m = Model::new();
    // Soft and heavy, so that the mechanical critical step is far above any dt used here.
    let k = m.add_material(material("rod", 1000.0, 1.0, 1.0, 0.0)).unwrap();
    for i in 0..=N {
        m.add_particle(Vec3::new(2.0 * R * i as f64, 0.0, 0.0), R, k).unwrap();
    }
    m.connect(None, 1e-9).unwrap();
    let all: Vec<u32> = (0..=N as u32).collect();
    m.fix(&all, dof::ALL, true).unwrap();
    m.settings.heat.reference = 0.0;
    m.enable_heat();
    m.set_thermal_material("rod", ThermalProps { conductivity: K, specific_heat: 1.0, expansion: 0.0 }).unwrap();
    let h = pair_conductance(K, K, R, R, 2.0 * R, true, m.settings.heat.bond_radius);
    assert!((h - K * R).abs() < 1e-15);
    m.particles.thermal.capacity.fill(h / lambda);
    m.clock.dt = dt;
    (m, h)
}

fn fix_ends(m: &mut Model) {
    m.groups.set("cold", vec![0]);
    m.groups.set("hot", vec![N as u32]);
    m.set_thermal_mode("cold", ThermalMode::Fixed(Some(0.0))).unwrap();
    m.set_thermal_mode("hot", ThermalMode::Fixed(Some(1.0))).unwrap();
}

fn run(m: Model, steps: u64) -> Model {
    let mut sim = Simulation::new(m);
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
    sim.model
}

/// The chain's temperatures after `n` steps of `dt` from T = 0 inside, T(0) = 0, T(N) = 1:
/// T_i = i/N + Σ_k b_k·sin(kπi/N)·decay(λ_k), λ_k = 4λ·sin²(kπ/2N).
fn series(lambda: f64, decay: impl Fn(f64) -> f64) -> Vec<f64> {
    let nf = N as f64;
    (0..=N)
        .map(|i| {
            let lin = i as f64 / nf;
            let mut t = lin;
            for k in 1..N {
                let kf = k as f64;
                let b: f64 =
                    (0..=N).map(|j| (0.0 - j as f64 / nf) * (kf * PI * j as f64 / nf).sin()).sum::<f64>() * 2.0 / nf;
                let lk = 4.0 * lambda * (kf * PI / (2.0 * nf)).sin().powi(2);
                t += b * (kf * PI * i as f64 / nf).sin() * decay(lk);
            }
            t
        })
        .collect()
}

// Ends held at 0 and 1: the steady profile is linear, T_i = i/N. A forward-Euler step of
// 0.4 s (the limit is C/ΣH = 0.5 s) for 3000 steps leaves the slowest mode at
// (1 − 0.4·0.098)^3000 ≈ 1e-52 of its start: what remains is round-off.
#[test]
fn a_chain_with_fixed_ends_settles_to_the_exact_linear_profile() {
    let (mut m, _) = chain(1.0, 0.4);
    fix_ends(&mut m);
    let m = run(m, 3000);
    for (i, t) in m.particles.thermal.temperature.iter().enumerate() {
        assert!((t - i as f64 / N as f64).abs() < 1e-12, "node {i}: {t}");
    }
}

// The published transient at t = 10 s (λ = 1 s⁻¹), within 1e-4 with a step of 1 ms; forward
// Euler's error there is O(Δt·λ_k²·t) ≈ 1e-5.
#[test]
fn the_chains_transient_at_ten_seconds_matches_the_series_solution() {
    let expected = [0.0, 0.030618, 0.066931, 0.114481, 0.178379, 0.262821, 0.370443, 0.501640, 0.654090, 0.822682, 1.0];
    let exact = series(1.0, |lk| (-lk * 10.0).exp());
    for (e, x) in expected.iter().zip(&exact) {
        assert!((e - x).abs() < 1e-6, "the series itself: {x} against {e}");
    }
    let (mut m, _) = chain(1.0, 1e-3);
    fix_ends(&mut m);
    let m = run(m, 10_000);
    assert!((m.clock.time - 10.0).abs() < 1e-9);
    for (i, (t, e)) in m.particles.thermal.temperature.iter().zip(&expected).enumerate() {
        assert!((t - e).abs() < 1e-4, "node {i}: {t} against {e}");
    }
}

// At a large step (0.4 s, 25 steps to t = 10 s) the answer is forward Euler's own: each mode
// decays by (1 − Δt·λ_k)^n, to round-off.
#[test]
fn at_a_large_step_the_chain_follows_forward_eulers_exact_discrete_form() {
    let (dt, steps) = (0.4, 25);
    let discrete = series(1.0, |lk| (1.0 - dt * lk).powi(steps));
    let (mut m, _) = chain(1.0, dt);
    fix_ends(&mut m);
    let m = run(m, steps as u64);
    for (i, (t, e)) in m.particles.thermal.temperature.iter().zip(&discrete).enumerate() {
        assert!((t - e).abs() < 1e-12, "node {i}: {t} against {e}");
    }
    // And a field step of 4 mechanical steps in 4 sub-steps is the same sequence.
    let (mut m, _) = chain(1.0, dt);
    fix_ends(&mut m);
    m.settings.heat.every = 4;
    m.settings.heat.substeps = 4;
    let m = run(m, 24);
    let discrete24 = series(1.0, |lk| (1.0 - dt * lk).powi(24));
    for (t, e) in m.particles.thermal.temperature.iter().zip(&discrete24) {
        assert!((t - e).abs() < 1e-12);
    }
}

// Nothing fixed, no source: the heat Σ C_i·T_i is conserved to round-off, with capacities
// that differ from element to element, and the temperatures even out at the weighted mean.
#[test]
fn insulated_ends_conserve_the_heat_to_round_off() {
    let (mut m, h) = chain(1.0, 0.2);
    for i in 0..=N {
        m.particles.thermal.capacity[i] = h * (1.0 + 0.3 * i as f64);
        m.particles.thermal.temperature[i] = ((i * 7) % 5) as f64;
    }
    let heat = |m: &Model| -> f64 {
        let t = &m.particles.thermal;
        t.capacity.iter().zip(&t.temperature).map(|(c, t)| c * t).sum()
    };
    let q0 = heat(&m);
    let m = run(m, 10_000);
    assert!(((heat(&m) - q0) / q0).abs() < 1e-13, "{} against {q0}", heat(&m));
    let mean = q0 / m.particles.thermal.capacity.iter().sum::<f64>();
    for t in &m.particles.thermal.temperature {
        assert!((t - mean).abs() < 1e-9);
    }
}

// A source of P watts on one end of an insulated chain adds P·t of heat.
#[test]
fn a_heat_source_adds_its_power_times_the_time() {
    let (mut m, h) = chain(1.0, 0.1);
    m.groups.set("heater", vec![0]);
    m.set_heat_source("heater", 2.5).unwrap();
    let m = run(m, 100);
    let t = &m.particles.thermal;
    let q: f64 = t.capacity.iter().zip(&t.temperature).map(|(c, t)| c * t).sum();
    assert!((q - 2.5 * 10.0).abs() < 1e-10, "{q}");
    assert!(t.temperature[0] > t.temperature[N] && h > 0.0);
}

// A cube-aligned FCC block (lattice constant L = √2·d) of slightly overlapping elements, held
// at T = 1 on its first [100] plane and 0 on its last, insulated elsewhere. In the steady state
// each interior element of a middle plane passes its heat to the next plane through its four
// contacts there, and each carries an area d² of the plane: k_eff = Q/(area·gradient) should be
// 2√2·H/d (with H the engine's Hertz-radius conductance) within 2 %.
#[test]
fn an_fcc_blocks_effective_conductivity_is_two_root_two_h_over_d() {
    let (d, overlap, planes, m_side) = (1.0, 1e-3, 8usize, 8usize);
    let half = d / 2f64.sqrt(); // L/2
    let r = (d + overlap) / 2.0;
    let mut m = Model::new();
    let k = m.add_material(material("grain", 1000.0, 1.0, 1.0, 0.0)).unwrap();
    let mut index = std::collections::HashMap::new();
    for i in 0..planes {
        for j in 0..m_side {
            for l in 0..m_side {
                if (i + j + l) % 2 == 0 {
                    let id =
                        m.add_particle(Vec3::new(i as f64 * half, j as f64 * half, l as f64 * half), r, k).unwrap();
                    index.insert((i, j, l), id);
                }
            }
        }
    }
    let n = m.len();
    let all: Vec<u32> = (0..n as u32).collect();
    m.fix(&all, dof::ALL, true).unwrap();
    m.settings.heat.reference = 0.0;
    m.enable_heat();
    m.set_thermal_material("grain", ThermalProps { conductivity: 1.0, specific_heat: 1.0, expansion: 0.0 }).unwrap();
    let h = pair_conductance(1.0, 1.0, r, r, d, false, 0.5);
    assert!(h > 0.0);
    // C = 12·H·1 s: the limit C/ΣH is 1 s; steps of 0.8 s.
    m.particles.thermal.capacity.fill(12.0 * h);
    m.clock.dt = 0.8;
    let hot: Vec<u32> = (0..n).filter(|&i| m.particles.pos[i].x < 0.1 * half).map(|i| i as u32).collect();
    let cold: Vec<u32> =
        (0..n).filter(|&i| m.particles.pos[i].x > (planes as f64 - 1.1) * half).map(|i| i as u32).collect();
    m.groups.set("hot", hot);
    m.groups.set("cold", cold);
    m.set_thermal_mode("hot", ThermalMode::Fixed(Some(1.0))).unwrap();
    m.set_thermal_mode("cold", ThermalMode::Fixed(Some(0.0))).unwrap();
    let m = run(m, 6000);
    let t = &m.particles.thermal.temperature;
    // Interior elements of plane 3 and their four neighbours in plane 4.
    let p = 3;
    let (mut q, mut count, mut grad) = (0.0, 0, 0.0);
    for j in 1..m_side - 1 {
        for l in 1..m_side - 1 {
            let Some(&a) = index.get(&(p, j, l)) else { continue };
            for (dj, dl) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                let b = index[&(p + 1, (j as i64 + dj) as usize, (l as i64 + dl) as usize)];
                q += h * (t[a] - t[b]);
                grad += (t[a] - t[b]) / half;
            }
            count += 1;
        }
    }
    let gradient = grad / (4 * count) as f64;
    let k_eff = q / (count as f64 * d * d * gradient);
    let expected = 2.0 * 2f64.sqrt() * h / d;
    assert!(((k_eff - expected) / expected).abs() < 0.02, "k_eff {k_eff} against {expected}");
    // The steady profile is linear: the gradient is (1 − 0)/((planes − 1)·L/2).
    let g_exact = 1.0 / ((planes - 1) as f64 * half);
    assert!(((gradient - g_exact) / g_exact).abs() < 1e-6, "gradient {gradient} against {g_exact}");
}

// Δt_f above C/ΣH is refused before the run, naming the element, its limit and the fix.
#[test]
fn a_field_step_above_the_stability_limit_is_refused_with_the_fix() {
    let (mut m, _) = chain(1.0, 0.6);
    fix_ends(&mut m);
    let mut sim = Simulation::new(m);
    let e = sim.run(10, &RunControl::default(), &mut |_| {}).unwrap_err();
    let Error::InvalidScene(msg) = &e else { panic!("{e}") };
    assert!(msg.contains("element 1") && msg.contains("5.000e-1 s") && msg.contains("d.heat_substeps to 2"), "{msg}");
    // Two sub-steps are stable.
    sim.model.settings.heat.substeps = 2;
    sim.run(10, &RunControl::default(), &mut |_| {}).unwrap();
}

// No capacity and heat on: refused, naming the material and the setting.
#[test]
fn an_element_without_heat_capacity_is_refused() {
    let (mut m, _) = chain(1.0, 0.1);
    m.particles.thermal.capacity[3] = 0.0;
    let e = Simulation::new(m).run(1, &RunControl::default(), &mut |_| {}).unwrap_err().to_string();
    assert!(e.contains("element 3") && e.contains("no heat capacity") && e.contains("specific_heat"), "{e}");
}

// r = r0·(1 + α·ΔT), the mass kept.
#[test]
fn a_free_elements_radius_grows_by_alpha_delta_t() {
    let mut m = Model::new();
    let k = m.add_material(material("steel", 7800.0, 1e5, 1e7, 0.3)).unwrap();
    m.add_particle(Vec3::zeros(), 1e-3, k).unwrap();
    m.settings.heat.reference = 20.0;
    m.enable_heat();
    m.set_thermal_material("steel", ThermalProps { conductivity: 50.0, specific_heat: 500.0, expansion: 1.2e-5 })
        .unwrap();
    m.set_temperatures(&[120.0]).unwrap();
    let mass = m.particles.mass[0];
    m.set_standard_dt().unwrap();
    let m = run(m, 3);
    assert!((m.particles.radius[0] - 1e-3 * (1.0 + 1.2e-5 * 100.0)).abs() < 1e-18, "{}", m.particles.radius[0]);
    assert_eq!(m.particles.mass[0], mass);
}

// A free bonded bar of 10 touching elements heated uniformly by ΔT = 100 K: its bonds push
// the grown elements apart until they touch again, so its length (centre to centre plus the
// end radii) grows by α·ΔT = 1.2e-3 of itself, within 1 % of that change.
#[test]
fn a_bonded_bars_length_grows_by_alpha_delta_t() {
    let (r, n) = (1e-3, 10usize);
    let mut m = Model::new();
    let mut steel = material("steel", 7800.0, 1e5, 1e7, 0.3);
    (steel.xb, steel.fs0) = (1e-4, 1e3);
    let k = m.add_material(steel).unwrap();
    for i in 0..n {
        m.add_particle(Vec3::new(2.0 * r * i as f64, 0.0, 0.0), r, k).unwrap();
    }
    m.connect(None, 1e-9).unwrap();
    let length =
        |m: &Model| m.particles.pos[n - 1].x - m.particles.pos[0].x + m.particles.radius[0] + m.particles.radius[n - 1];
    let l0 = length(&m);
    m.settings.heat.reference = 20.0;
    m.enable_heat();
    m.set_thermal_material("steel", ThermalProps { conductivity: 50.0, specific_heat: 500.0, expansion: 1.2e-5 })
        .unwrap();
    m.set_temperatures(&vec![120.0; n]).unwrap();
    m.settings.damping = 0.3;
    m.set_standard_dt().unwrap();
    let m = run(m, 20_000);
    let strain = (length(&m) - l0) / l0;
    assert!(((strain - 1.2e-3) / 1.2e-3).abs() < 0.01, "strain {strain}");
    // Uniform temperature: conduction changed nothing.
    assert!(m.particles.thermal.temperature.iter().all(|t| (t - 120.0).abs() < 1e-9));
}

// A clamped bar: n touching elements on the x axis between two fixed walls, heated by ΔT.
// Each grows by α·ΔT·r, and the bar's free growth 2·n·r·α·ΔT is taken up by n − 1 element
// pairs (linear springs of stiffness kn: two elements' kn in series) and two wall contacts
// (2·kn each) in series, so every contact carries F = 2·r·kn·α·ΔT; over the bar's cross
// section (2r)² that is σ = E·α·ΔT with the chain's modulus E = kn/(2r). At rest (damped),
// the walls' load and every pair's force against F to 1e-6.
#[test]
fn a_clamped_bars_thermal_stress_is_e_alpha_delta_t() {
    let (r, n, kn, alpha, dt_heat) = (1e-3, 8usize, 1e5, 1.2e-5, 100.0);
    let mut m = Model::new();
    m.settings.normal = NormalKind::Linear;
    let k = m.add_material(material("steel", 7800.0, kn, 1e7, 0.3)).unwrap();
    for i in 0..n {
        m.add_particle(Vec3::new(2.0 * r * i as f64, 0.0, 0.0), r, k).unwrap();
    }
    let area = 4.0 * r * r;
    let right = 2.0 * r * (n - 1) as f64 + r;
    m.add_wall(Wall::plane("left", Vec3::new(-r, 0.0, 0.0), Vec3::x(), area).unwrap()).unwrap();
    m.add_wall(Wall::plane("right", Vec3::new(right, 0.0, 0.0), -Vec3::x(), area).unwrap()).unwrap();
    // The bar only shortens or lengthens: no buckling sideways.
    let all: Vec<u32> = (0..n as u32).collect();
    m.fix(&all, dof::Y | dof::Z, true).unwrap();
    m.settings.heat.reference = 20.0;
    m.enable_heat();
    m.set_thermal_material("steel", ThermalProps { conductivity: 50.0, specific_heat: 500.0, expansion: alpha })
        .unwrap();
    m.set_temperatures(&vec![20.0 + dt_heat; n]).unwrap();
    m.settings.damping = 0.3;
    m.set_standard_dt().unwrap();
    let m = run(m, 40_000);

    let expected = 2.0 * r * kn * alpha * dt_heat;
    let rel = |x: f64| (x - expected).abs() / expected;
    for w in &m.walls {
        assert!(rel(w.normal_force) < 1e-6, "wall {}: {} N against {expected} N", w.name, w.normal_force);
    }
    let p = &m.particles;
    for i in 0..n - 1 {
        let f = kn * (p.radius[i] + p.radius[i + 1] - (p.pos[i + 1] - p.pos[i]).norm());
        assert!(rel(f) < 1e-6, "pair {i}: {f} N against {expected} N");
    }
    let stress = m.walls[0].normal_force / area;
    let e_chain = kn / (2.0 * r);
    assert!((stress - e_chain * alpha * dt_heat).abs() < 1e-6 * stress, "σ {stress} against E·α·ΔT");
}

// A checkpoint carries the thermal lanes and the heat settings: a loaded model continues the
// transient bit for bit.
#[test]
fn a_checkpoint_carries_the_temperatures_and_continues_bit_for_bit() {
    use matdem_engine::checkpoint::{decode, encode};
    let (mut m, _) = chain(1.0, 0.1);
    fix_ends(&mut m);
    let m = run(m, 20);
    let bytes = encode(&m, &[]);
    let loaded = decode(&bytes).unwrap().model;
    assert_eq!(loaded.particles.thermal.temperature, m.particles.thermal.temperature);
    assert_eq!(loaded.settings.heat, m.settings.heat);
    let (a, b) = (run(m, 30), run(loaded, 30));
    assert_eq!(a.particles.thermal.temperature, b.particles.thermal.temperature);
}

/// erfc by Abramowitz & Stegun 7.1.26 (absolute error under 1.5e-7).
fn erfc(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.3275911 * x);
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    poly * (-x * x).exp()
}

// A semi-infinite bar: the first element held at T = 1 from t = 0, the rest at 0. Its
// continuum limit is T(x, t) = erfc(x/(2√(D·t))) with diffusivity D = λ·d² (λ = H/C, d the
// element spacing). For a bar of unit diffusivity at t = 0.05 s, over x ∈ [0, 1] m, the
// largest error falls as the elements shrink, by about four each halving (d = 1/10, 1/20,
// 1/40, steps of 0.2/λ; measured 4.8e-3, 1.2e-3, 3.0e-4), and is under 1e-3 at d = 1/40.
// The bar is twice as long as the heat reaches.
#[test]
fn a_semi_infinite_bar_converges_to_the_erf_solution_as_the_elements_shrink() {
    let (diffusivity, t_end) = (1.0, 0.05);
    let mut errors = Vec::new();
    for n in [10usize, 20, 40] {
        let d = 1.0 / n as f64;
        let lambda = diffusivity / (d * d);
        let dt = 0.2 / lambda;
        let steps = (t_end / dt).round() as u64;
        let mut m = Model::new();
        let k = m.add_material(material("rod", 1000.0, 1.0, 1.0, 0.0)).unwrap();
        for i in 0..=2 * n {
            m.add_particle(Vec3::new(2.0 * R * i as f64, 0.0, 0.0), R, k).unwrap();
        }
        m.connect(None, 1e-9).unwrap();
        let all: Vec<u32> = (0..=2 * n as u32).collect();
        m.fix(&all, dof::ALL, true).unwrap();
        m.settings.heat.reference = 0.0;
        m.enable_heat();
        m.set_thermal_material("rod", ThermalProps { conductivity: K, specific_heat: 1.0, expansion: 0.0 }).unwrap();
        m.particles.thermal.capacity.fill(K * R / lambda);
        m.groups.set("end", vec![0]);
        m.set_thermal_mode("end", ThermalMode::Fixed(Some(1.0))).unwrap();
        m.clock.dt = dt;
        let m = run(m, steps);
        let t = &m.particles.thermal.temperature;
        let time = steps as f64 * dt;
        let worst = (0..=n)
            .map(|i| (t[i] - erfc(i as f64 * d / (2.0 * (diffusivity * time).sqrt()))).abs())
            .fold(0.0, f64::max);
        errors.push(worst);
    }
    eprintln!("largest error against erfc at d = 1/10, 1/20, 1/40: {errors:?}");
    assert!(errors[1] < errors[0] && errors[2] < errors[1], "errors {errors:?}");
    assert!(errors[2] < 1e-3, "errors {errors:?}");
}
