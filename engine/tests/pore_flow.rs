//! Pore density flow against conservation laws and Darcy: mass conserved to round-off
//! when the boundaries are impermeable, the undrained pressure rise K_f·ΔV_p/V_p of an
//! isotropically compressed sample, and steady flow through a packed column under a fixed
//! pressure difference (constant flux, linear pressure, the permeability of the network's
//! own conductances), plus the stability guard of the explicit update.

use matdem_engine::effects::pore_flow::{BoundaryKind, Fluid, PoreBoundary, PoreFlow};
use matdem_engine::physics::Vec3;
use matdem_engine::{Error, Material, Model};

const A: f64 = 1e-3;

/// Simple-cubic column of nx × ny × nz spheres of radius 0.4·a (throats open).
fn column(nx: usize, ny: usize, nz: usize) -> Model {
    let mut m = Model::new();
    let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4 * A).unwrap()).unwrap();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                m.add_particle(Vec3::new(i as f64, j as f64, k as f64) * A, 0.4 * A, mat).unwrap();
            }
        }
    }
    m.set_dt(1e-6).unwrap();
    m
}

/// A soft fluid, so the stable flow step is long and tests are quick.
fn fluid() -> Fluid {
    Fluid { bulk_modulus: 1e6, max_substeps: 1_000_000, ..Fluid::default() }
}

#[test]
fn mass_is_conserved_to_round_off_with_impermeable_boundaries() {
    let m = column(5, 5, 5);
    let mut f = PoreFlow::new(&m, fluid()).unwrap();
    // An uneven start: some pores hold 1 % more fluid.
    for p in (0..f.mass.len()).step_by(7) {
        f.mass[p] *= 1.01;
    }
    f.update_pressure();
    let m0 = f.total_mass();
    let (_, crit) = f.critical_dt();
    for _ in 0..3000 {
        f.substep(0.9 * crit);
    }
    let drift = (f.total_mass() - m0).abs() / m0;
    assert!(drift < 1e-13, "mass changed by {drift:e} of itself");
    assert_eq!(f.boundary_mass, 0.0);
    // And it has spread out: the pressures are nearly uniform.
    let (lo, hi) = f.pressure.iter().fold((f64::MAX, f64::MIN), |(a, b), &p| (a.min(p), b.max(p)));
    assert!(hi - lo < 1e-3 * hi.abs(), "pressure still ranges {lo}..{hi}");
}

#[test]
fn undrained_compression_raises_pressure_by_bulk_modulus_times_volume_strain() {
    let mut m = column(5, 5, 5);
    let mut f = PoreFlow::new(&m, fluid()).unwrap();
    let v0: f64 = f.network.volume.iter().sum();
    // Isotropic compression by 0.5 % about the centre; radii unchanged (no overlaps at 0.4a).
    let c = Vec3::repeat(2.0 * A);
    for x in &mut m.particles.pos {
        *x = c + (*x - c) * 0.995;
    }
    f.advance(&m, 1e-9).unwrap();
    let v1: f64 = f.network.volume.iter().sum();
    // Let the fluid even out (impermeable boundaries), then compare.
    let (_, crit) = f.critical_dt();
    for _ in 0..4000 {
        f.substep(0.9 * crit);
    }
    let want = f.fluid.bulk_modulus * (v0 - v1) / v1;
    let mean = f.pressure.iter().zip(&f.network.volume).map(|(p, v)| p * v).sum::<f64>() / v1;
    for (i, p) in f.pressure.iter().enumerate() {
        assert!((p / want - 1.0).abs() < 1e-6, "pore {i}: {p} Pa vs K_f·ΔV_p/V_p = {want} Pa");
    }
    println!("ΔV_p/V_p = {:.4e}, p = {mean:.4e} Pa, K_f·ΔV_p/V_p = {want:.4e} Pa", (v0 - v1) / v1);
}

/// Pores within half a spacing of the column's ends hold p_in (bottom) and 0 (top).
fn darcy(nz: usize, p_in: f64) -> (Model, PoreFlow) {
    let m = column(4, 4, nz);
    let mut f = PoreFlow::new(&m, fluid()).unwrap();
    let top = (nz - 1) as f64 * A;
    let big = 1.0;
    f.set_boundaries(vec![
        PoreBoundary::boxed(Vec3::repeat(-big), Vec3::new(big, big, 0.5 * A), BoundaryKind::Pressure(p_in)),
        PoreBoundary::boxed(Vec3::new(-big, -big, top - 0.5 * A), Vec3::repeat(big), BoundaryKind::Pressure(0.0)),
    ])
    .unwrap();
    (m, f)
}

#[test]
fn darcy_column_flows_steadily_with_a_linear_pressure_and_the_networks_permeability() {
    let nz = 12;
    let p_in = 1000.0;
    let (_m, mut f) = darcy(nz, p_in);
    let (_, crit) = f.critical_dt();
    let mut steps = 0;
    loop {
        for _ in 0..2000 {
            f.substep(0.9 * crit);
        }
        steps += 2000;
        let (qin, qout) = (f.boundary_flow[0], -f.boundary_flow[1]);
        if (qin - qout).abs() < 1e-9 * qin || steps > 400_000 {
            break;
        }
    }
    let (qin, qout) = (f.boundary_flow[0], -f.boundary_flow[1]);
    assert!(qin > 0.0 && (qin / qout - 1.0).abs() < 1e-8, "inflow {qin:e} vs outflow {qout:e} after {steps} sub-steps");

    // The same flux crosses every horizontal plane between the reservoirs.
    let net = &f.network;
    for k in 2..nz - 2 {
        let z = (k as f64 + 0.5) * A;
        let q: f64 = net
            .throats
            .iter()
            .zip(&f.flow)
            .map(|(th, q)| {
                let (za, zb) = (net.centre[th.a as usize].z, net.centre[th.b as usize].z);
                if za < z && zb >= z {
                    *q
                } else if zb < z && za >= z {
                    -*q
                } else {
                    0.0
                }
            })
            .sum();
        assert!((q / qin - 1.0).abs() < 1e-8, "flux {q:e} through z = {z:e} vs inflow {qin:e}");
    }

    // Against the network's own conductances: the steady Kirchhoff solution.
    let mut s = f.clone();
    let iters = s.solve_steady(1e-13).unwrap();
    let qs = s.boundary_flow[0];
    assert!(
        (qin / qs - 1.0).abs() < 1e-7,
        "explicit steady flux {qin:e} vs Kirchhoff's {qs:e} ({iters} CG iterations)"
    );

    // The pressure falls linearly between the reservoirs (pores away from the side walls).
    let top = (nz - 1) as f64 * A;
    let l = top - A; // between the reservoir pore layers' inner edges (z = 0.5a … top − 0.5a)
    let (mut worst, mut count) = (0.0f64, 0);
    for p in 0..net.pore_count() {
        let c = net.centre[p];
        if c.z < 1.5 * A || c.z > top - 1.5 * A {
            continue;
        }
        let (zi, zo) = (0.5 * A, top - 0.5 * A);
        let _ = l;
        let linear = p_in * (zo - c.z) / (zo - zi);
        worst = worst.max((f.pressure[p] - linear).abs() / p_in);
        count += 1;
    }
    println!("{count} interior pores; largest departure from the linear profile {:.2} % of Δp", worst * 100.0);
    assert!(worst < 0.05, "pressure departs {:.1} % of Δp from linear", worst * 100.0);

    // Permeability k = μ·Q·L / (A·Δp) over the pores' span, reported.
    let area = (3.0 * A) * (3.0 * A);
    let k = f.fluid.viscosity * qin * (top - A) / (area * p_in);
    println!("permeability of the simple-cubic (r = 0.4 a) network: {k:.4e} m² ({:.4e} a²)", k / (A * A));
}

#[test]
fn flow_beyond_its_stable_step_is_stopped_by_the_guard_naming_the_pore() {
    let m = column(4, 4, 4);
    let mut f = PoreFlow::new(&m, Fluid { bulk_modulus: 2.2e9, max_substeps: 10, ..Fluid::default() }).unwrap();
    let (pore, crit) = f.critical_dt();
    let e = f.advance(&m, 1e3 * crit).unwrap_err();
    let Error::Unstable(i) = &e else { panic!("expected the guard's error, got {e}") };
    assert_eq!(i.critical_dt, crit);
    let s = e.to_string();
    assert!(s.contains(&format!("pore {pore}")), "{s}");
    assert!(s.contains("max_substeps"), "{s}");
    assert!(s.contains("lower its bulk_modulus"), "{s}");
    // Under the limit, the step is split into sub-steps and runs.
    let mut f = PoreFlow::new(&m, Fluid { max_substeps: 2000, ..f.fluid.clone() }).unwrap();
    f.advance(&m, 1e3 * crit).unwrap();
    assert_eq!(f.substeps, (1e3 / matdem_engine::effects::pore_flow::flow::FLOW_SAFETY).ceil() as u32);
}

/// A per-material permeability factor scales the throats its elements bound: every element of
/// one material with factor 0.01 gives exactly 0.01 of the Darcy flux; a layer of it across
/// the column (its throats the harmonic mean of their corners' factors) cuts the flux further
/// than the same material's share alone would suggest, and never below the whole column's.
#[test]
fn a_materials_permeability_factor_scales_the_conductance_of_its_throats() {
    let nz = 8;
    let flux = |f: &PoreFlow| {
        let mut s = f.clone();
        s.solve_steady(1e-13).unwrap();
        s.boundary_flow[0]
    };
    let (mut m, f) = darcy(nz, 1000.0);
    let q1 = flux(&f);
    let mut tight = f.fluid.clone();
    tight.permeability.insert("grain".into(), 0.01);
    let mut g = f.clone();
    g.fluid = tight.clone();
    g.network.refresh(&m, &tight);
    let q_all = flux(&g);
    assert!((q_all / q1 / 0.01 - 1.0).abs() < 1e-9, "all tight: {q_all:e} vs 0.01 × {q1:e}");
    // The middle layers (z = 3a, 4a) of another material, "clay", tight.
    let clay = m.add_material(Material::from_micro("clay", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4 * A).unwrap()).unwrap();
    for (i, x) in m.particles.pos.iter().enumerate() {
        if (x.z / A - 3.5).abs() < 0.6 {
            m.particles.material[i] = clay;
        }
    }
    let mut layered = f.fluid.clone();
    layered.permeability.insert("clay".into(), 0.01);
    let mut l = f.clone();
    l.fluid = layered.clone();
    l.network.refresh(&m, &layered);
    let q_layer = flux(&l);
    println!("Darcy flux: open {q1:.4e}, all at 0.01 {q_all:.4e}, a tight layer of two {q_layer:.4e} m³/s");
    assert!(q_layer < 0.2 * q1 && q_layer > q_all, "a tight layer: {q_layer:e} (open {q1:e}, all tight {q_all:e})");
}

#[test]
fn a_borehole_region_holds_exactly_the_pores_whose_centres_lie_within_its_radius_of_its_axis() {
    use matdem_engine::effects::pore_flow::PoreRegion;
    let m = column(6, 6, 6);
    let mut f = PoreFlow::new(&m, fluid()).unwrap();
    // A borehole along a slanted axis through the column's middle.
    let (center, axis, radius) = (Vec3::new(2.5, 2.5, 2.5) * A, Vec3::new(1.0, 2.0, 0.5), 1.1 * A);
    let hole = PoreRegion::cylinder(center, axis, radius).unwrap();
    f.set_boundaries(vec![PoreBoundary { region: hole, kind: BoundaryKind::Pressure(5e3), temperature: None }])
        .unwrap();
    let u = axis.normalize();
    let mut inside = 0;
    for (p, c) in f.network.centre.iter().enumerate() {
        let r = c - center;
        let off_axis = (r - u * r.dot(&u)).norm();
        // The test's own distance, away from the rim where rounding could decide.
        if (off_axis - radius).abs() < 1e-9 * A {
            continue;
        }
        let held = f.region[p] == 0;
        assert_eq!(held, off_axis < radius, "pore {p} at {off_axis:e} m from the axis");
        if held {
            inside += 1;
            // Held through its mass: p = K_f·(m/(ρ0·V) − 1) rounds in the last bits.
            assert!((f.pressure[p] / 5e3 - 1.0).abs() < 1e-12, "pore {p}: {} Pa, not the borehole's", f.pressure[p]);
        }
    }
    assert!(inside >= 10 && inside < f.network.centre.len() / 2, "{inside} pores in the borehole");

    // Bad shapes are refused with what to give instead.
    for (axis, radius) in [(Vec3::zeros(), A), (Vec3::new(f64::NAN, 0.0, 1.0), A), (Vec3::z(), 0.0), (Vec3::z(), -A)] {
        let e = PoreRegion::cylinder(center, axis, radius).unwrap_err().to_string();
        assert!(e.contains("axis") || e.contains("radius"), "{e}");
    }
}

/// A simple-cubic block (spacing a, r = 0.4a) with a hole drilled along y through it (the
/// elements within 1.1a of the axis: a plus-shaped shaft open at both faces), its borehole
/// region held at p, every other pore at rest at gauge 0: (element, offset from the axis).
fn drilled_block(p: f64) -> (Model, Vec<Vec3>) {
    use matdem_engine::effects::pore_flow::PoreRegion;
    let mut m = Model::new();
    let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, 0.4 * A).unwrap()).unwrap();
    let (center, axis) = (Vec3::new(3.0, 2.0, 3.0) * A, Vec3::y());
    let mut offsets = Vec::new();
    for i in 0..7 {
        for j in 0..5 {
            for k in 0..7 {
                let x = Vec3::new(i as f64, j as f64, k as f64) * A;
                let off = Vec3::new(x.x - center.x, 0.0, x.z - center.z);
                if off.norm() > 1.1 * A {
                    m.add_particle(x, 0.4 * A, mat).unwrap();
                    offsets.push(off);
                }
            }
        }
    }
    m.set_dt(1e-6).unwrap();
    m.set_pore_fluid(fluid()).unwrap();
    m.enable_pore_flow().unwrap();
    m.add_pore_boundary(PoreRegion::cylinder(center, axis, 1.5 * A).unwrap(), BoundaryKind::Pressure(p)).unwrap();
    (m, offsets)
}

#[test]
fn a_pressurised_borehole_open_at_the_faces_pushes_its_wall_into_the_rock() {
    use matdem_engine::effects::pore_flow::pressure_forces::pressure_force;
    let p = 1e4;
    let (m, offsets) = drilled_block(p);
    let f = m.pores.as_ref().unwrap();
    let net = &f.network;
    let pos = &m.particles.pos;
    // The shaft's open space is the well's: pores there, held at p, the rest at 0.
    let held: Vec<usize> = (0..net.pore_count()).filter(|&q| f.region[q] == 0).collect();
    assert!(!held.is_empty(), "no pore in the borehole");
    for (q, pq) in f.pressure.iter().enumerate() {
        let want = if f.region[q] == 0 { p } else { 0.0 };
        assert!((pq - want).abs() < 1e-9 * p, "pore {q}: {pq} Pa, want {want}");
    }
    let tet_volume = |t: usize| {
        let v = net.tri.tets[t].v.map(|i| pos[i as usize]);
        ((v[0] - v[3]).dot(&(v[1] - v[3]).cross(&(v[2] - v[3]))) / 6.0).abs()
    };
    let bore: f64 = (0..net.tri.tets.len()).filter(|&t| f.region[net.tet_pore[t] as usize] == 0).map(tet_volume).sum();
    // The shaft between the centres of its wall's elements: a cross of five a × a squares, 4a long.
    let shaft = 5.0 * A * A * 4.0 * A;
    assert!(bore > 0.9 * shaft && bore < 1.6 * shaft, "the well's tetrahedra hold {bore:e} m³, the shaft {shaft:e}");

    // The force is p·∂V/∂x, so the wall's push along its offsets from the axis is p·dV/dε
    // for the radial stretch x⊥ → (1 + ε)·x⊥, which is 2·p·V: outward, and exact.
    let push: f64 = (0..m.len()).map(|i| pressure_force(net, &f.pressure, pos, i).dot(&offsets[i])).sum();
    assert!((push / (2.0 * p * bore) - 1.0).abs() < 1e-9, "Σ F·x⊥ = {push:e}, 2·p·V = {:e}", 2.0 * p * bore);
    // Element by element: each wall element is pushed away from the axis, none into the hole.
    for i in 0..m.len() {
        let radial = pressure_force(net, &f.pressure, pos, i).dot(&offsets[i]);
        assert!(radial >= -1e-12 * p * A * A * A, "element {i} at {:?} is pulled toward the axis: {radial:e}", pos[i]);
    }
}
