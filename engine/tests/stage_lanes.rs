//! Pay for use: a plan allocates the lanes of an optional stage only when it has the stage,
//! on both backends. The CPU's lanes are counted on the model after a run (every lane as long
//! as it is allocated, in bytes per particle) against the plan's own account
//! ([`StepPlan::lane_sets`]); the GPU's through its device buffers, where a lane the plan does
//! not have is a 128-byte placeholder. Switching the heat ledger off changes no motion, bit
//! for bit.

use crate::common::material;
use matdem_engine::backend::RunControl;
use matdem_engine::builder::simple_cubic;
use matdem_engine::effects::parallel_bond::physics::ParallelBondParams;
use matdem_engine::plan::Stage;
use matdem_engine::{Material, Model, NormalKind, Simulation, Vec3, Wall};

const N: usize = 4 * 4 * 4;
/// The core lanes: pos, vel, force, origin (3 × f64 each), radius, mass (f64), material (u32),
/// fixed (u8).
const CORE: usize = 4 * 24 + 2 * 8 + 4 + 1;

/// What a scene switches on.
#[derive(Clone, Copy, Default)]
struct Effects {
    friction: bool,
    dashpot: bool,
    rotation: bool,
    bonds: bool,
    ledger: bool,
    /// The bonds made parallel bonds (the `parallel_bond` stage).
    parallel: bool,
}

/// A 4 × 4 × 4 block of touching spheres on a floor, under gravity, with `e`'s effects.
fn block(e: Effects) -> Model {
    let mut mat: Material = material("m", 2650.0, 1e5, 1e7, 0.3);
    mat.ks = if e.friction { 4e4 } else { 0.0 };
    mat.mu_p = if e.friction { 0.5 } else { 0.0 };
    mat.restitution = if e.dashpot { 0.5 } else { 1.0 };
    mat.xb = 1e-4;
    let mut m = Model::new();
    let k = m.add_material(mat).unwrap();
    let (r, s) = (1e-3, 1.999e-3);
    for x in simple_cubic(4, 4, 4, s, Vec3::repeat(0.5 * s)) {
        m.add_particle(x, r, k).unwrap();
    }
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1e-4).unwrap()).unwrap();
    m.settings.normal = NormalKind::Linear;
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    m.settings.rotation = e.rotation;
    m.settings.heat_ledger = e.ledger;
    if e.rotation {
        m.particles.enable_rotation();
    }
    if e.bonds {
        m.connect(None, 1e-5).unwrap();
    }
    if e.parallel {
        m.bond_parallel(ParallelBondParams {
            lambda: 1.0,
            e_star: 1e8,
            k_ratio: 2.0,
            sigma_c: 1e9,
            cohesion: 1e9,
            phi: 0.5,
        })
        .unwrap();
    }
    m.set_standard_dt().unwrap();
    m
}

fn run(sim: &mut Simulation, steps: u64) {
    sim.run(steps, &RunControl::default(), &mut |_| {}).unwrap();
}

/// The plan's lane sets by name, and the bytes per particle the CPU model holds after a run:
/// its particle lanes, and the parallel bonds' rows less their per-pair entries (which the
/// plan accounts per bond end, [`StepPlan::pair_bytes`]) and the last row's end.
fn cpu_lanes(e: Effects) -> (Vec<&'static str>, usize, usize, Simulation) {
    let mut sim = Simulation::new(block(e));
    run(&mut sim, 20);
    let plan = sim.plan().clone();
    let sets = plan.lane_sets().iter().map(|s| s.stage).collect();
    let bonds = sim.model.parallel_bonds.bytes();
    let rows = if bonds > 0 { bonds - plan.pair_bytes() - 4 } else { 0 };
    let held = sim.model.particles.bytes() + rows;
    assert_eq!(held % N, 0);
    (sets, plan.bytes_per_particle(), held / N, sim)
}

// Without friction, dashpot, damping, moving walls, bonds or rotation nothing can release heat:
// the plan has the core lanes only, and that is what the model holds (117 B a particle), even
// with the ledger switched on. Each effect then adds exactly its lanes: friction and the dashpot
// a heat lane each (8 B), bonds the breakage lane, rotation ang_vel, torque and angle (72 B); with the
// ledger off no heat lane at all.
#[test]
fn each_plan_allocates_the_lanes_of_its_stages_only_on_the_cpu() {
    let on = Effects { ledger: true, ..Default::default() };
    let cases = [
        (on, vec!["core"], CORE, vec![]),
        (Effects { friction: true, ..on }, vec!["core", "heat_ledger"], CORE + 8, vec!["friction"]),
        (
            Effects { friction: true, dashpot: true, ..on },
            vec!["core", "heat_ledger"],
            CORE + 16,
            vec!["contact_damping", "friction"],
        ),
        (Effects { friction: true, dashpot: true, ledger: false, ..on }, vec!["core"], CORE, vec![]),
        (Effects { bonds: true, ..on }, vec!["core", "heat_ledger"], CORE + 8, vec!["breakage"]),
        (
            Effects { rotation: true, friction: true, ..on },
            vec!["core", "rotation", "heat_ledger"],
            CORE + 72 + 8,
            vec!["friction"],
        ),
        (
            Effects { rotation: true, friction: true, dashpot: true, bonds: true, ledger: false, parallel: false },
            vec!["core", "rotation"],
            CORE + 72,
            vec![],
        ),
        // Parallel bonds: rotation (which they need), their rows (a u32 row start a particle,
        // plus per bond end an id and the state, counted apart) and the breakage lane.
        (
            Effects { bonds: true, parallel: true, ..on },
            vec!["core", "rotation", "parallel_bond", "heat_ledger"],
            CORE + 72 + 4 + 8,
            vec!["breakage"],
        ),
        (
            Effects { bonds: true, parallel: true, ledger: false, ..on },
            vec!["core", "rotation", "parallel_bond"],
            CORE + 76,
            vec![],
        ),
    ];
    for (k, (effects, sets, bytes, heat)) in cases.into_iter().enumerate() {
        let (got_sets, planned, held, mut sim) = cpu_lanes(effects);
        eprintln!("case {k}: {got_sets:?}, planned {planned} B, held {held} B per particle");
        assert_eq!(got_sets, sets, "case {k}: lane sets");
        assert_eq!(planned, bytes, "case {k}: the plan's bytes per particle");
        assert_eq!(held, bytes, "case {k}: the model's bytes per particle");
        assert_eq!(sim.plan().heat.names(), heat, "case {k}: heat lanes");
        assert_eq!(sim.plan().stages().contains(&Stage::HeatLedger), !heat.is_empty(), "case {k}: heat stage");
        let allocated: Vec<usize> = sim.model.particles.heat.lanes().iter().map(|l| l.len()).collect();
        assert_eq!(allocated.iter().filter(|&&l| l == N).count(), heat.len(), "case {k}: {allocated:?}");
        assert_eq!(sim.model.particles.rotation.is_some(), effects.rotation || effects.parallel, "case {k}: rotation");
        // Per bond end: the partner's id (4 B) and the bond's state (shear, normal, bending, twist as
        // f64, the status: 72 B); nothing without the stage.
        let plan = sim.plan().clone();
        let pb = &sim.model.parallel_bonds;
        assert_eq!(plan.stages().contains(&Stage::ParallelBond), effects.parallel, "case {k}: stage");
        assert_eq!(plan.pair_bytes(), pb.other.len() * (4 + 72), "case {k}: per-pair bytes");
        assert_eq!(pb.bytes() == 0, !effects.parallel, "case {k}: parallel bond lanes");
    }
}

// The ledger is bookkeeping: the same scene with and without it moves bit for bit the same
// (positions, velocities, spins after 200 steps with friction, dashpot, bonds and rotation on,
// some bonds breaking or not); only the energies' heat differs, positive with it, 0 without.
#[test]
fn the_heat_ledger_changes_no_motion() {
    let effects = Effects { friction: true, dashpot: true, rotation: true, bonds: true, ledger: true, parallel: false };
    let mut with = Simulation::new(block(effects));
    let mut without = Simulation::new(block(Effects { ledger: false, ..effects }));
    // Shake the block so that contacts slide and the dashpots work.
    for sim in [&mut with, &mut without] {
        for (i, v) in sim.model.particles.vel.iter_mut().enumerate() {
            *v = Vec3::new(0.01 * ((i * 7) % 5) as f64, -0.01 * ((i * 3) % 4) as f64, 0.02);
        }
        run(sim, 200);
    }
    let (a, b) = (&with.model.particles, &without.model.particles);
    assert!(a.pos == b.pos && a.vel == b.vel, "the ledger changed the motion");
    assert_eq!(a.rotation.as_ref().unwrap().ang_vel, b.rotation.as_ref().unwrap().ang_vel);
    let (ea, eb) = (with.energies(), without.energies());
    eprintln!("heat with the ledger {:e} J, without {:e} J", ea.heat(), eb.heat());
    assert!(ea.heat() > 0.0 && ea.heat_friction > 0.0 && ea.heat_contact_damping > 0.0);
    assert_eq!(eb.heat(), 0.0);
    assert_eq!(ea.mechanical(), eb.mechanical());
}

// On the GPU the same plans: the heat ledger's buffer holds one 8-byte (hi, lo) f32 pair per
// particle and cause the plan has, a 128-byte placeholder without the ledger; the rotation lanes
// (angular velocity, torque and angle: three vec4<f32>, 48 B a particle) exist only with rotation;
// the applied loads' force (and, with a torque, torque) lanes only with loads. Measured as differences of the
// device's buffer bytes between plans that differ in that one stage.
#[cfg(feature = "gpu")]
#[test]
fn each_plan_allocates_the_lanes_of_its_stages_only_on_the_gpu() {
    use matdem_engine::backend::gpu::GpuBackend;
    use matdem_engine::backend::Backend;
    let Some(ctx) = crate::common::gpu("stage_lanes_gpu") else { return };
    let device_bytes = |e: Effects| {
        let mut m = block(e);
        let mut b = GpuBackend::prepare(ctx.clone(), &m).unwrap();
        matdem_engine::simulation::run_steps(&mut b, &mut m, 5, 0, &RunControl::default(), &mut |_| {}, &mut |_| {})
            .unwrap();
        b.bytes()
    };
    let base = Effects { friction: true, dashpot: true, ..Default::default() };
    let off = device_bytes(base);
    let on = device_bytes(Effects { ledger: true, ..base });
    assert_eq!(on - off, N * 2 * 8 - 128, "heat ledger: 2 causes");
    let rot = device_bytes(Effects { rotation: true, ..base });
    assert_eq!(rot - off, 3 * (N * 16 - 128), "rotation lanes");
    // Applied forces: a vec4<f32> a particle, the torque lane a 128-byte placeholder; with a
    // torque, both lanes (against the same rotation plan).
    let loads = |torque: bool| {
        let mut m = block(Effects { rotation: true, ..base });
        m.apply_force(&[0, 1], Vec3::new(1e-4, 0.0, 0.0)).unwrap();
        if torque {
            m.apply_torque(&[2], Vec3::new(0.0, 0.0, 1e-8)).unwrap();
        }
        let mut b = GpuBackend::prepare(ctx.clone(), &m).unwrap();
        matdem_engine::simulation::run_steps(&mut b, &mut m, 5, 0, &RunControl::default(), &mut |_| {}, &mut |_| {})
            .unwrap();
        b.bytes()
    };
    assert_eq!(loads(false) - rot, N * 16 + 128, "applied force lane");
    assert_eq!(loads(true) - rot, 2 * N * 16, "applied force and torque lanes");
    // Parallel bonds against the same bonds as MatDEM's, rotation on in both: their row starts
    // (N + 1 u32), per bond end an id and a 48-byte f32 state, and a 32-byte uniform.
    let bonded = Effects { rotation: true, bonds: true, ..base };
    let entries = Simulation::new(block(Effects { parallel: true, ..bonded })).model.parallel_bonds.other.len();
    let pb = device_bytes(Effects { parallel: true, ..bonded }) - device_bytes(bonded);
    assert_eq!(pb, 4 * (N + 1) + entries * (4 + 48) + 32, "parallel bond lanes");
}

// The field stages: with heat and water off (every plan above) the plan has neither stage and
// the model holds none of their lanes. Heat on adds the conduction lanes (temperature,
// capacity, conductivity, source, conductance: f64; the mode: a byte) = 41 B a particle, and
// expansion its coefficient and reference radius (16 B); the water table adds a stage and no
// lane (it reads the core's).
#[test]
fn the_field_stages_allocate_their_lanes_only_when_the_scene_enables_them() {
    use matdem_engine::effects::conduction::ThermalProps;
    let on = Effects { ledger: false, ..Default::default() };
    let (sets, planned, held, mut sim) = cpu_lanes(on);
    assert_eq!((sets, planned, held), (vec!["core"], CORE, CORE));
    assert!(!sim.plan().has(Stage::Conduction) && !sim.plan().has(Stage::Buoyancy));
    assert_eq!(sim.model.particles.thermal.bytes(), 0);
    let plan = sim.plan().to_string();
    let off = plan.split("not simulated: ").nth(1).unwrap();
    assert!(off.contains("heat conduction") && off.contains("buoyancy"), "{plan}");

    for (expansion, bytes) in [(0.0, 41), (1e-5, 57)] {
        let mut m = block(on);
        m.enable_heat();
        m.set_thermal_material("m", ThermalProps { conductivity: 1.0, specific_heat: 800.0, expansion }).unwrap();
        m.settings.water.level = Some(2e-3);
        let mut sim = Simulation::new(m);
        run(&mut sim, 20);
        let plan = sim.plan().clone();
        assert!(plan.has(Stage::Conduction) && plan.has(Stage::Buoyancy));
        let names: Vec<&str> = plan.stages().iter().map(|s| s.name()).collect();
        assert_eq!(names.join(" "), "walls neighbours contact_forces wall_forces buoyancy integrate conduction guard");
        let sets: Vec<&str> = plan.lane_sets().iter().map(|s| s.stage).collect();
        assert_eq!(sets, ["core", "conduction"]);
        assert_eq!(plan.bytes_per_particle(), CORE + bytes, "expansion {expansion}");
        assert_eq!(sim.model.particles.bytes(), N * (CORE + bytes), "expansion {expansion}");
        let text = plan.to_string();
        let lanes =
            format!("conduction {bytes} B (temperature, capacity, conductivity, source, conductance, thermal_mode");
        assert!(text.contains(&lanes) && text.contains("buoyancy(water level z = 0.002 m"), "{text}");
    }
}

// On the GPU the conduction lanes are (T, C, k, P) as a vec4<f32>, the next temperature, the
// conductance and the mode (4 B each): 28 B a particle, and a 128-byte placeholder for the
// expansion lane when no element expands; buoyancy adds no lane.
#[cfg(feature = "gpu")]
#[test]
fn the_field_stages_allocate_their_lanes_only_when_the_scene_enables_them_on_the_gpu() {
    use matdem_engine::backend::gpu::GpuBackend;
    use matdem_engine::backend::Backend;
    use matdem_engine::effects::conduction::ThermalProps;
    let Some(ctx) = crate::common::gpu("field_lanes_gpu") else { return };
    let device_bytes = |heat: bool, water: bool| {
        let mut m = block(Effects::default());
        if heat {
            m.enable_heat();
            m.set_thermal_material("m", ThermalProps { conductivity: 1.0, specific_heat: 800.0, expansion: 0.0 })
                .unwrap();
        }
        if water {
            m.settings.water.level = Some(2e-3);
        }
        let mut b = GpuBackend::prepare(ctx.clone(), &m).unwrap();
        matdem_engine::simulation::run_steps(&mut b, &mut m, 5, 0, &RunControl::default(), &mut |_| {}, &mut |_| {})
            .unwrap();
        b.bytes()
    };
    let off = device_bytes(false, false);
    assert_eq!(device_bytes(true, false) - off, N * 28 + 128, "conduction lanes");
    assert_eq!(device_bytes(false, true), off, "buoyancy has no lane");
}

// Rolling resistance: cdt brings the rotation lanes it needs (a torque) and nothing else; epsd
// adds a rolling spring per row entry and per particle and wall (24 B each), which the model
// holds as the plan accounts them. With μ_r = 0 the plan has no stage and moves bit for bit as
// one without the setting.
#[test]
fn rolling_resistance_allocates_lanes_only_for_epsd() {
    use matdem_engine::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
    let base = Effects { friction: true, ..Default::default() };
    let with = |model: RollingModel, mu_r: f64| {
        let mut m = block(base);
        m.settings.rolling = Some(RollingResistance::new(model, mu_r, 0.0).unwrap());
        let mut sim = Simulation::new(m);
        run(&mut sim, 20);
        sim
    };
    let mut off = Simulation::new(block(base));
    run(&mut off, 20);
    let mut zero = with(RollingModel::Cdt, 0.0);
    assert_eq!(off.plan().lane_sets(), zero.plan().lane_sets());
    assert_eq!(off.model.particles.pos, zero.model.particles.pos, "μ_r = 0 moves as no rolling resistance");
    assert_eq!(off.model.particles.vel, zero.model.particles.vel);
    let plan = off.plan().to_string();
    assert!(plan.split("not simulated: ").nth(1).unwrap().contains("rolling resistance"), "{plan}");

    let mut cdt = with(RollingModel::Cdt, 0.1);
    let sets: Vec<&str> = cdt.plan().lane_sets().iter().map(|s| s.stage).collect();
    assert_eq!(sets, ["core", "rotation"]);
    assert_eq!(cdt.plan().bytes_per_particle(), CORE + 72);
    assert_eq!(cdt.model.particles.bytes(), N * (CORE + 72));
    assert!(cdt.model.contacts.rolling.is_empty() && cdt.model.wall_rolling.is_empty());
    assert!(cdt.plan().stages().contains(&Stage::RollingResistance));

    let mut epsd = with(RollingModel::Epsd, 0.1);
    let plan = epsd.plan().clone();
    let sets: Vec<&str> = plan.lane_sets().iter().map(|s| s.stage).collect();
    assert_eq!(sets, ["core", "rotation", "rolling_resistance"]);
    // One wall: 24 B a particle; 24 B per row entry.
    assert_eq!(plan.bytes_per_particle(), CORE + 72 + 24);
    assert_eq!(plan.row_entry_bytes(), 24);
    let c = &epsd.model.contacts;
    assert_eq!(c.rolling.len(), c.other.len());
    assert_eq!(epsd.model.wall_rolling.len() * 24, N * 24);
}

// On the GPU cdt keeps no lanes: its device buffers are the rotation plan's, byte for byte
// (whose epsd lanes are 128-byte placeholders, as every plan's). epsd's springs replace the two
// placeholders with a vec4<f32> per row slot and per particle and wall.
#[cfg(feature = "gpu")]
#[test]
fn gpu_rolling_resistance_lanes() {
    use matdem_engine::backend::gpu::GpuBackend;
    use matdem_engine::backend::Backend;
    use matdem_engine::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
    let Some(ctx) = crate::common::gpu("rolling_lanes_gpu") else { return };
    let device_bytes = |rolling: Option<RollingModel>| {
        let mut m = block(Effects { friction: true, rotation: true, ..Default::default() });
        if let Some(model) = rolling {
            m.settings.rolling = Some(RollingResistance::new(model, 0.1, 0.0).unwrap());
        }
        let mut b = GpuBackend::prepare(ctx.clone(), &m).unwrap();
        matdem_engine::simulation::run_steps(&mut b, &mut m, 5, 0, &RunControl::default(), &mut |_| {}, &mut |_| {})
            .unwrap();
        b.bytes()
    };
    let cdt = device_bytes(Some(RollingModel::Cdt));
    assert_eq!(cdt, device_bytes(None));
    let springs = device_bytes(Some(RollingModel::Epsd)) - cdt + 2 * 128;
    // 16 B per slot (cap slots a row, at least 16) and per particle and wall (one wall).
    assert_eq!(springs % (16 * N), 0, "{springs}");
    let cap = springs / (16 * N) - 1;
    assert!(cap >= 16, "{cap} slots a row");
}
