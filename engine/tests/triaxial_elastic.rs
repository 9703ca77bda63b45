//! Issue 34 item 4's last check: a bonded sample of a trained material, in the triaxial cell
//! (the membrane of the `confining_pressure` stage between two platens), shows the E and ν it
//! was trained for at small strain. The material is trained on a box sample (the soil of
//! training.rs); the cell's cylinder is cut from a larger packing of the same statistics,
//! bonded with the trained material, confined at σ3 = 0.05·Cu and loaded axially to a tenth of
//! the peak strain. E and ν are read as the training reads them: the axial stress (the platens')
//! against the grains' axial strain (the slope of their displacement against position), and the
//! grains' lateral strain in x and y against it. Tolerance (the issue's): E within 10 %, ν
//! within 0.05 (measured on 2 cores, about 30 s: ~825 grains, E 5.34e7 Pa against the target
//! 5e7 and the training sample's 4.95e7, ν 0.165 against 0.15 and 0.150; side stress σ3 + 0.8 %).
//!
//! The training sample has 600 elements. With 200 the material was fitted to that one small
//! packing: over eight packings (four training seeds, each with ids as placed and in Z-order)
//! the cell read E 1.01–1.16 times the training's, so the check passed or failed by the
//! packing's luck. With 600, five packings (four with ids in Z-order, one as placed) read
//! 0.94–1.08 times it and 0.93–1.07 of the target, ν 0.149–0.170.

use matdem_engine::backend::RunControl;
use matdem_engine::effects::confining_pressure::ConfineRequest;
use matdem_engine::training::{train, PackedSample, SampleSpec, TrainOptions};
use matdem_engine::walls::{WallMotion, WallShape};
use matdem_engine::{Balance, MacroProperties, Model, Simulation, Vec3, Wall};

fn soil() -> MacroProperties {
    MacroProperties { young: 5e7, poisson: 0.15, tensile: 2e4, compressive: 2e5, internal_friction: 0.6 }
}

/// Least-squares slope of the displacement component `k` against the starting position `k`.
fn strain(m: &Model, ids: &[usize], origin: &[Vec3], k: usize) -> f64 {
    let n = ids.len() as f64;
    let x: Vec<f64> = ids.iter().map(|&i| origin[i][k]).collect();
    let u: Vec<f64> = ids.iter().map(|&i| m.particles.pos[i][k] - origin[i][k]).collect();
    let (mx, mu) = (x.iter().sum::<f64>() / n, u.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&u).map(|(a, b)| (a - mx) * (b - mu)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

fn plane_z(m: &Model, name: &str) -> f64 {
    match m.walls[m.wall_index(name).unwrap()].shape {
        WallShape::Plane { point, .. } => point.z,
        _ => unreachable!(),
    }
}

#[test]
fn a_trained_material_shows_its_e_and_nu_in_the_triaxial_cell() {
    let ctl = RunControl::default();
    let t = soil();
    let opts = TrainOptions {
        sample: SampleSpec { elements: 600, ..SampleSpec::default() },
        density: 2000.0,
        steps_to_peak: 4000.0,
        ..TrainOptions::default()
    };
    let trained = train("soil", &t, &opts, &ctl, &mut |_| {}).unwrap();
    let best = trained.best_round();
    let material = best.material.clone();
    eprintln!(
        "trained in {} rounds: E {:.4e} Pa, ν {:.4}",
        trained.rounds.len(),
        best.measured.young,
        best.measured.poisson
    );

    // A cylinder cut from a taller packing of the same grains, its axis on the packing's.
    let spec = SampleSpec { elements: 1600, seed: 5, ..opts.sample };
    let packed = PackedSample::pack(&spec, &material, &ctl).unwrap();
    let (lo, hi) =
        packed.pos.iter().fold((Vec3::repeat(f64::MAX), Vec3::repeat(f64::MIN)), |(lo, hi), x| (lo.inf(x), hi.sup(x)));
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi.x - lo.x).min(hi.y - lo.y) - 1e-3;
    let keep = |x: &Vec3| (x.x - centre.x).hypot(x.y - centre.y) < radius;
    let cylinder = PackedSample {
        pos: packed.pos.iter().filter(|x| keep(x)).map(|x| Vec3::new(x.x - centre.x, x.y - centre.y, x.z)).collect(),
        radius: packed.pos.iter().zip(&packed.radius).filter(|(x, _)| keep(x)).map(|(_, r)| *r).collect(),
        steps: 0,
        thickness: None,
    };
    let mut m = cylinder.bonded(&material, &ctl).unwrap();
    let n = m.len();
    let p = &m.particles;
    let z0 = p.pos.iter().zip(&p.radius).map(|(x, r)| x.z - r).fold(f64::MAX, f64::min);
    let z1 = p.pos.iter().zip(&p.radius).map(|(x, r)| x.z + r).fold(f64::MIN, f64::max);
    let area = std::f64::consts::PI * radius * radius;
    for (name, z, normal) in [("bottom", z0, Vec3::z()), ("top_platen", z1, -Vec3::z())] {
        let mut w = Wall::plane(name, Vec3::new(0.0, 0.0, z), normal, area).unwrap();
        w.friction = Some(0.0);
        m.add_wall(w).unwrap();
    }
    let sigma3 = 0.05 * t.compressive;
    m.confine(ConfineRequest {
        pressure: sigma3,
        bottom: "bottom".into(),
        top: "top_platen".into(),
        axis: [0.0, 0.0],
        bands: None,
        sectors: None,
    })
    .unwrap();
    // Isotropic: the top platen servoed to σ3 too, then balanced.
    let dt = m.clock.dt;
    let top = m.wall_index("top_platen").unwrap();
    m.walls[top].motion = WallMotion::Servo { stress: sigma3, max_speed: 2e-3 * 1e-3 / dt };
    let mut sim = Simulation::new(m);
    sim.balance(Balance::Tolerance { ratio: 1e-3, max_steps: 40_000 }, &ctl, &mut |_| {}).unwrap();
    let iso = sim.model.walls[top].stress();
    let membrane = sim.model.membrane().unwrap();
    eprintln!("{n} grains, R {radius:.4e} m; isotropic: platen {iso:.4e} Pa, side {:.4e} Pa", membrane.stress);

    // Axial loading to a tenth of the expected peak strain, quasi-statically, then held.
    let m = &mut sim.model;
    let height = plane_z(m, "top_platen") - plane_z(m, "bottom");
    let target = 0.1 * t.compressive / t.young;
    let steps = 8000u64;
    m.walls[top].motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -target * height / (steps as f64 * dt)));
    let origin = m.particles.pos.clone();
    let r_mean = m.mean_radius();
    // Grains more than two diameters from the platens: the end layers take up the platens'
    // contact compliance, which is not the material's.
    let ids: Vec<usize> =
        (0..n).filter(|&i| origin[i].z > z0 + 4.0 * r_mean && origin[i].z < z1 - 4.0 * r_mean).collect();
    let s0 = m.walls[top].stress();
    sim.run(steps, &ctl, &mut |_| {}).unwrap();
    sim.model.walls[top].motion = WallMotion::Fixed;
    sim.balance(Balance::Tolerance { ratio: 1e-3, max_steps: 20_000 }, &ctl, &mut |_| {}).unwrap();
    let m = &sim.model;
    let axial = -strain(m, &ids, &origin, 2);
    let lateral = 0.5 * (strain(m, &ids, &origin, 0) + strain(m, &ids, &origin, 1));
    let ds = m.walls[top].stress() - s0;
    let (young, poisson) = (ds / axial, lateral / axial);
    let side = m.membrane().unwrap().stress;
    eprintln!(
        "cell: Δσ1 {ds:.4e} Pa over ε_a {axial:.4e}: E {young:.4e} Pa (trained {:.4e}), ν {poisson:.4} (trained {:.4}); side {side:.4e} Pa",
        best.measured.young, best.measured.poisson
    );
    assert!((side - sigma3).abs() < 0.02 * sigma3, "side stress {side} against σ3 {sigma3}");
    assert!((young / t.young - 1.0).abs() < 0.10, "E {young} against the trained {}", t.young);
    assert!((poisson - t.poisson).abs() < 0.05, "ν {poisson} against the trained {}", t.poisson);
}
