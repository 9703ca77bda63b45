//! The zoned builder (paper 001 §1, §3) on small chambers: every region holds its target
//! porosity after packing, the mixing layer still does after deposition under gravity and
//! confinement, no fine grain ends up beyond the mixing layer, the packer stops by its
//! settling criterion, group E of the CPT study packs on every seed, and a packing does not
//! depend on the thread count.
//! Heavy: run in release mode.

use matdem_engine::backend::RunControl;
use matdem_engine::simulation::{Balance, Simulation};
use matdem_engine::zoned::{zone_report, ZoneReport, ZoneSpec, PACK_BALANCE_RATIO, PACK_MAX_STEPS, SETTLE_SPEED};
use matdem_engine::{Material, Model, Vec3, WallMotion};

/// Paper 001 §3's grains at half size: a fine core of 3 mm grains, a mixing layer of 3 and
/// 9 mm grains (the paper's 1 : 3 layer of group E, 6 + 18 mm) one and a third coarse grains
/// wide, an outer zone 1.7 coarse grains wide; six coarse grains high. Paper porosities
/// (zones 0.3545, layer 0.33).
fn spec() -> ZoneSpec {
    ZoneSpec {
        radius: vec![0.018, 0.039],
        grain_d: vec![3e-3, 9e-3],
        mix: vec![0.012],
        height: 0.054,
        ..ZoneSpec::default()
    }
}

fn print(what: &str, rep: &[ZoneReport]) {
    eprintln!("{what}:");
    for z in rep {
        eprintln!(
            "  {:6} {:.4}–{:.4} m  n {:4}  porosity {:.4} (target {:.4})  coordination {:.2}",
            z.name, z.r_in, z.r_out, z.count, z.porosity, z.target_porosity, z.coordination
        );
    }
}

/// The farthest centre of a grain of material `name` from the axis (m).
fn farthest(m: &Model, name: &str) -> f64 {
    let k = m.material_index(name).unwrap();
    (0..m.len())
        .filter(|&i| m.particles.material[i] == k)
        .map(|i| (m.particles.pos[i].x.powi(2) + m.particles.pos[i].y.powi(2)).sqrt())
        .fold(0.0, f64::max)
}

/// Confinement on the ring and the top platen, as the CPT chamber's servo walls (paper 001:
/// 300 kPa; here a tenth, the grains are half the paper's).
const CONFINEMENT: f64 = 30e3;

#[test]
fn mixing_layer_holds_its_porosity_and_keeps_fine_grains_in() {
    let t = std::time::Instant::now();
    // Paper 001 §3: Kn = Ks = 5e5 N/m for the 6 mm grains, μ 0.5; here for the 3 mm ones.
    let sand = Material::from_micro("sand", 2650.0, 5e5, 5e5, 0.0, 0.0, 0.5, 1.5e-3).unwrap();
    let spec = spec();
    let (model, regions, pack) = spec.pack(&sand, true, &RunControl::default()).unwrap();
    let built = zone_report(&model, &regions, &spec.grain_d);
    print("after packing", &built);
    eprintln!("packing: {pack:?}, {} grains, {:.1} s", model.len(), t.elapsed().as_secs_f64());
    let names: Vec<&str> = built.iter().map(|z| z.name.as_str()).collect();
    assert_eq!(names, ["zone1", "mix12", "zone2"]);
    for z in &built {
        assert!(
            (z.porosity - z.target_porosity).abs() < 0.02,
            "{} porosity {} against target {}",
            z.name,
            z.porosity,
            z.target_porosity
        );
        assert!(z.coordination > 3.0, "{} is not packed: coordination {}", z.name, z.coordination);
    }
    // The soft zone walls held every grain's centre in its annulus within 5 % of its radius,
    // and the packing ended by its settling criterion, well before its cap.
    assert!(pack.deepest_stray < 0.05, "a grain ended {} of its radius outside its annulus", pack.deepest_stray);
    assert!(
        pack.settled && pack.settle_steps < PACK_MAX_STEPS,
        "the packing ran to its cap: {} settling steps, unbalanced ratio {}, mean speed {:.2e} r/step",
        pack.settle_steps,
        pack.unbalanced_ratio,
        pack.mean_speed
    );
    assert!(pack.unbalanced_ratio < PACK_BALANCE_RATIO || pack.mean_speed < SETTLE_SPEED);
    // Fine grains sit no farther out than their layer's edge plus 5 % of their radius.
    let fine_edge = regions[1].r_out + 0.05 * 0.5 * spec.grain_d[0];
    assert!(farthest(&model, "sand_zone1") <= fine_edge, "a fine grain beyond the layer after packing");
    // The coarse grains carry the scaled material: Kn ∝ d, Kn/Ks fixed.
    let k = model.material_index("sand_zone2").unwrap() as usize;
    assert!((model.materials[k].kn / sand.kn - 3.0).abs() < 1e-12);
    let in_groups: usize = names.iter().map(|g| model.groups.get(g).unwrap().len()).sum();
    assert_eq!(in_groups, model.len(), "every grain belongs to one region group");

    // Deposition under gravity, then the ring and the top platen servo-controlled to the
    // confinement, rotation on, as the CPT chamber.
    let mut sim = Simulation::new(model);
    sim.model.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    sim.model.settings.local_damping = 0.7;
    sim.model.particles.enable_rotation();
    let dt = sim.model.clock.dt;
    for wall in ["top_platen", "ring"] {
        let w = sim.model.wall_index(wall).unwrap();
        sim.model.walls[w].motion = WallMotion::Servo { stress: CONFINEMENT, max_speed: 2e-3 * 1.5e-3 / dt };
    }
    let rep = sim
        .balance(Balance::Tolerance { ratio: 0.02, max_steps: 30_000 }, &RunControl::default(), &mut |_| {})
        .unwrap();
    let m = &sim.model;
    let settled = zone_report(m, &regions, &spec.grain_d);
    print("after deposition and confinement", &settled);
    let (top, ring) = (m.wall_index("top_platen").unwrap(), m.wall_index("ring").unwrap());
    eprintln!(
        "deposition: {} steps, unbalanced ratio {:?}, stress top {:.0} Pa, ring {:.0} Pa; {:.1} s",
        rep.steps,
        rep.unbalanced_ratio,
        m.walls[top].stress(),
        m.walls[ring].stress(),
        t.elapsed().as_secs_f64()
    );
    for w in [top, ring] {
        assert!((m.walls[w].stress() / CONFINEMENT - 1.0).abs() < 0.1, "{} not confined", m.walls[w].name);
    }
    // The layer keeps its target porosity (paper 001: 0.33) within 0.02.
    let mix = &settled[1];
    eprintln!(
        "mixing layer: packed {:.4}, confined {:.4}, target {:.4} (off by {:+.4})",
        built[1].porosity,
        mix.porosity,
        mix.target_porosity,
        mix.porosity - mix.target_porosity
    );
    assert!(
        (mix.porosity - mix.target_porosity).abs() < 0.02,
        "mixing layer porosity {} after deposition and confinement, target {}",
        mix.porosity,
        mix.target_porosity
    );
    // No fine grain sank into the coarse zone: none beyond the layer's edge by more than one
    // fine grain's radius (a fine grain nested in the pocket between the coarse zone's first
    // grains, no deeper).
    let edge = regions[1].r_out + 0.5 * spec.grain_d[0];
    let out = farthest(m, "sand_zone1");
    eprintln!(
        "farthest fine grain centre {out:.5} m; layer edge {:.5} m, + one fine radius {edge:.5} m",
        regions[1].r_out
    );
    assert!(out <= edge, "a fine grain moved to ρ = {out} beyond the mixing layer (edge {edge})");
}

/// A chamber laid out as group E of the CPT study (examples/cpt): a fine core, a mixing
/// layer of 6 and 18 mm grains and an outer zone one 18 mm grain wide, three high, but
/// smaller across (1,100 grains against quick mode's 2,500). Quick mode's E failed on seed 3
/// ("particle 29 overlaps particle 1347 by 56 %": a fine grain put back onto a coarse one at
/// once) and on seed 2 fired a grain through the ring; the soft zone walls hold the regions
/// with a force instead. Every seed 1–5 packs, and keeps every fine grain in the layer.
#[test]
fn group_e_packs_on_seeds_1_to_5_with_fine_grains_held_in_the_layer() {
    let sand = Material::from_micro("sand", 2650.0, 5e5, 5e5, 0.0, 0.0, 0.5, 3e-3).unwrap();
    for seed in 1..=5 {
        let t = std::time::Instant::now();
        let spec = ZoneSpec {
            radius: vec![0.030, 0.060],
            grain_d: vec![6e-3, 18e-3],
            mix: vec![0.020],
            height: 0.054,
            seed,
            ..ZoneSpec::default()
        };
        let (model, regions, pack) =
            spec.pack(&sand, true, &RunControl::default()).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let ring = model.wall_index("ring").unwrap();
        let deepest = (0..model.len())
            .map(|i| {
                let (_, gap) = model.walls[ring].normal_and_distance(&model.particles.pos[i]);
                (model.particles.radius[i] - gap) / model.particles.radius[i]
            })
            .fold(0.0f64, f64::max);
        let out = farthest(&model, "sand_zone1");
        eprintln!(
            "seed {seed}: {} grains, {pack:?}; farthest fine grain {out:.5} m (layer edge {:.5}); deepest into \
             the ring {deepest:.4} r; {:.1} s",
            model.len(),
            regions[1].r_out,
            t.elapsed().as_secs_f64()
        );
        assert!(out <= regions[1].r_out + 0.05 * 3e-3, "seed {seed}: a fine grain at ρ = {out} beyond the layer");
        assert!(pack.deepest_stray < 0.05, "seed {seed}: a grain {} r outside its annulus", pack.deepest_stray);
        // A wall contact under the packing's pressure (1–2 % of a radius), not a grain fired
        // through the ring (as seed 2 did in quick mode before).
        assert!(deepest < 0.05, "seed {seed}: a grain {deepest} of its radius into the ring");
    }
}

/// The packer settles by its force balance, well before its cap, on a chamber laid out as
/// the CPT's group B: a fine core (6 mm) and an outer zone of twice the size with the same
/// Kn, whose grains have 2.8× the fine ones' period at their real mass. Before the packing
/// gave every size the fine grains' mass per stiffness and left the grains held by their
/// zone walls out of the ratio, these packings never reached the ratio 0.05 (0.070–0.079
/// when their mean speed ended them after 10,100–13,900 settling steps; quick mode's B–D
/// ran to the 20,000-step cap in 5 of 15 packings); now 3,600–8,500 steps by the ratio.
#[test]
fn a_two_size_chamber_of_equal_stiffness_settles_by_its_force_balance_before_half_the_cap() {
    let sand = Material::from_micro("sand", 2650.0, 5e5, 5e5, 0.0, 0.0, 0.5, 3e-3).unwrap();
    for seed in 1..=3 {
        let spec = ZoneSpec {
            radius: vec![0.024, 0.048],
            grain_d: vec![6e-3, 12e-3],
            mix: vec![0.0],
            height: 0.036,
            seed,
            ..ZoneSpec::default()
        };
        let (model, regions, pack) = spec.pack(&sand, false, &RunControl::default()).unwrap();
        let rep = zone_report(&model, &regions, &spec.grain_d);
        eprintln!("seed {seed}: {} grains, {pack:?}", model.len());
        print("packed", &rep);
        assert!(
            pack.settled && pack.unbalanced_ratio < PACK_BALANCE_RATIO,
            "seed {seed}: not settled by the force balance: ratio {} after {} settling steps (mean speed {:.2e})",
            pack.unbalanced_ratio,
            pack.settle_steps,
            pack.mean_speed
        );
        assert!(pack.settle_steps <= PACK_MAX_STEPS / 2, "seed {seed}: {} settling steps", pack.settle_steps);
        // The real masses are back: each grain's mass is its material's density times its volume.
        for i in 0..model.len() {
            let m = &model.materials[model.particles.material[i] as usize];
            let want = m.density * 4.0 / 3.0 * std::f64::consts::PI * model.particles.radius[i].powi(3);
            assert!((model.particles.mass[i] / want - 1.0).abs() < 1e-12, "seed {seed}: grain {i}'s mass");
        }
        // The core holds its porosity (0.360, 0.360, 0.371 measured; 0.346–0.368 before).
        // The outer zone, two coarse grains wide between the core and the ring, is wall on
        // both sides: 0.38–0.40, before as now, so it is not judged here.
        let core = &rep[0];
        assert!((core.porosity - core.target_porosity).abs() < 0.02, "seed {seed}: core porosity {}", core.porosity);
    }
}

/// Same seed, same packing, whatever the thread count: the zone walls act grain by grain
/// between chunks, in no order that threads could change.
#[test]
fn a_zoned_packing_does_not_depend_on_the_thread_count() {
    let sand = Material::from_micro("sand", 2650.0, 5e5, 5e5, 0.0, 0.0, 0.5, 3e-3).unwrap();
    let spec = ZoneSpec {
        radius: vec![0.012, 0.027],
        grain_d: vec![6e-3, 9e-3],
        mix: vec![0.010],
        height: 0.024,
        seed: 7,
        ..ZoneSpec::default()
    };
    let pack = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| spec.pack(&sand, true, &RunControl::default()).unwrap())
    };
    let (a, _, ra) = pack(1);
    let (b, _, rb) = pack(2);
    eprintln!("{} grains; one thread {ra:?}; two {rb:?}", a.len());
    assert_eq!(ra, rb);
    assert_eq!(a.particles.pos, b.particles.pos, "positions differ between one and two threads");
    assert_eq!(a.particles.radius, b.particles.radius);
}
