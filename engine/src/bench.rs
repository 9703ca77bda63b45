//! The standard throughput scene and its measurement, shared by `matdem-rs bench` and any
//! Rust program that wants comparable figures.
//!
//! The scene is the one other DEM codes are measured on (LIGGGHTS input
//! `shared/bench/liggghts_lattice.in`): a simple cubic lattice of equal spheres, spaced a
//! hair closer than their diameter so every lattice neighbour touches, standing in a box of
//! five planes under gravity, with Hertz–Mindlin contacts, friction, a restitution dashpot
//! and rotation. Nothing here prints: the caller formats the [`BenchReport`].
//!
//! The stirred variant ([`LatticeScene::stirred`]) starts every grain with a random velocity,
//! so the grains collide and the neighbour rows are rebuilt every hundred steps or so, as in a
//! deposition: what a scene in motion costs, row builds included.

use crate::backend::RunControl;
use crate::builder::simple_cubic;
use crate::error::Result;
use crate::materials::Material;
use crate::model::{Model, NormalKind, TangentialKind};
use crate::physics::contact_law::PairState;
use crate::physics::Vec3;
use crate::plan::LaneSet;
use crate::simulation::Simulation;
use crate::walls::Wall;
use std::mem::size_of;
use std::time::Instant;

/// The lattice scene. [`Default`] is the standard 20 × 20 × 50 one.
#[derive(Debug, Clone, PartialEq)]
pub struct LatticeScene {
    pub nx: usize,
    pub ny: usize,
    pub nz: usize,
    /// Sphere diameter (m).
    pub diameter: f64,
    /// Lattice spacing (m); a little under the diameter, so neighbours touch.
    pub spacing: f64,
    /// Density (kg/m³).
    pub density: f64,
    /// Young's modulus (Pa) and Poisson's ratio of the Hertz–Mindlin contact.
    pub young: f64,
    pub poisson: f64,
    /// Friction coefficient, between particles and against the walls.
    pub friction: f64,
    pub restitution: f64,
    /// Gravitational acceleration, pointing down −z (m/s²).
    pub gravity: f64,
    /// Simulate rotation (LIGGGHTS' `nve/sphere` integrates it, so the standard scene does).
    pub rotation: bool,
    /// Time step (s).
    pub dt: f64,
    /// Each grain starts with each velocity component drawn uniformly from ±`stir` (m/s; a
    /// fixed seed); 0: at rest.
    pub stir: f64,
    /// A 2D scene ([`LatticeScene::planar`]): one layer in the x–z plane (ny = 1, centres at
    /// y = 0), the model made 2D, no walls in y.
    pub planar: bool,
}

impl Default for LatticeScene {
    fn default() -> Self {
        LatticeScene {
            nx: 20,
            ny: 20,
            nz: 50,
            diameter: 1e-3,
            spacing: 0.99999e-3,
            density: 2650.0,
            young: 5e6,
            poisson: 0.3,
            friction: 0.5,
            restitution: 0.5,
            gravity: 9.81,
            rotation: true,
            dt: 1e-6,
            stir: 0.0,
            planar: false,
        }
    }
}

impl LatticeScene {
    /// The standard scene scaled to about `n` particles, keeping its 20:20:50 aspect:
    /// nx = ny = round((n/2.5)^(1/3)), nz = round(n/(nx·ny)).
    pub fn with_particles(n: usize) -> Self {
        let side = ((n as f64 / 2.5).cbrt().round() as usize).max(1);
        let nz = ((n as f64 / (side * side) as f64).round() as usize).max(1);
        LatticeScene { nx: side, ny: side, nz, ..Self::default() }
    }

    /// The scene with every grain started at up to ±0.5 m/s a component: the soft Hertz
    /// contacts (E = 5 MPa) take the collisions (a head-on one at 1 m/s overlaps by about a
    /// fifth of the radius, within the guard's half), and a grain moves half the rows' skin in
    /// a few hundred steps.
    pub fn stirred(self) -> Self {
        LatticeScene { stir: 0.5, ..self }
    }

    /// The same count in 2D: a square lattice in the x–z plane of the standard scene's 20:50
    /// aspect, nx = round((n/2.5)^(1/2)), nz = round(n/nx), made 2D. What a 2D scene costs
    /// against a 3D one of as many particles (each touches 4 against 6; the walls in y go).
    pub fn planar(self) -> Self {
        let n = self.particles();
        let nx = ((n as f64 / 2.5).sqrt().round() as usize).max(1);
        let nz = ((n as f64 / nx as f64).round() as usize).max(1);
        LatticeScene { nx, ny: 1, nz, planar: true, ..self }
    }

    pub fn particles(&self) -> usize {
        self.nx * self.ny * self.nz
    }

    /// Builds the model: spheres on the lattice with the first centres half a spacing from
    /// the floor and the side walls, planes at x = 0, x = Lx, y = 0, y = Ly and z = 0
    /// (L = n·spacing), rows built, time step set.
    pub fn build(&self) -> Result<Model> {
        let bytes = crate::memory_budget::CPU_BYTES_PER_PARTICLE;
        crate::memory_budget::check_fits("the bench scene", self.particles() as u64, bytes)?;
        let mut m = Model::new();
        let r = 0.5 * self.diameter;
        m.add_material(Material {
            name: "bench".into(),
            density: self.density,
            // Only bonds use the linear springs; give the Hertz-equivalent ones (E = Kn/(πR)).
            kn: self.young * std::f64::consts::PI * r,
            ks: 0.0,
            xb: 0.0,
            fs0: 0.0,
            mu_p: self.friction,
            young: self.young,
            poisson: self.poisson,
            restitution: self.restitution,
            provenance: Default::default(),
        })?;
        m.settings.normal = NormalKind::Hertz;
        m.settings.tangential = TangentialKind::Mindlin;
        m.settings.gravity = Vec3::new(0.0, 0.0, -self.gravity);
        m.settings.rotation = self.rotation;
        let s = self.spacing;
        let (lx, ly, lz) = (self.nx as f64 * s, self.ny as f64 * s, self.nz as f64 * s);
        let mut rng = crate::builder::Rng::new(1);
        let mut stir = || self.stir * (2.0 * rng.uniform() - 1.0);
        let y0 = if self.planar { 0.0 } else { 0.5 * s };
        for x in simple_cubic(self.nx, self.ny, self.nz, s, Vec3::new(0.5 * s, y0, 0.5 * s)) {
            let id = m.add_particle(x, r, 0)?;
            if self.stir > 0.0 {
                let (vx, vy, vz) = (stir(), stir(), stir());
                m.particles.vel[id] = Vec3::new(vx, if self.planar { 0.0 } else { vy }, vz);
            }
        }
        m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), lx * ly)?)?;
        m.add_wall(Wall::plane("x0", Vec3::zeros(), Vec3::x(), ly * lz)?)?;
        m.add_wall(Wall::plane("x1", Vec3::new(lx, 0.0, 0.0), -Vec3::x(), ly * lz)?)?;
        if self.planar {
            m.make_planar(Some(self.diameter))?;
        } else {
            m.add_wall(Wall::plane("y0", Vec3::zeros(), Vec3::y(), lx * lz)?)?;
            m.add_wall(Wall::plane("y1", Vec3::new(0.0, ly, 0.0), -Vec3::y(), lx * lz)?)?;
        }
        if self.rotation {
            m.particles.enable_rotation();
        }
        m.set_dt(self.dt)?;
        crate::neighbours::rebuild(&mut m);
        Ok(m)
    }
}

/// What one benchmark run measured.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchReport {
    pub particles: usize,
    pub warmup: u64,
    pub steps: u64,
    /// Wall-clock time of the timed steps (s).
    pub seconds: f64,
    pub particle_steps_per_s: f64,
    /// Mean particle–particle contacts per particle at the end, each pair counted at both
    /// ends, walls not counted: what LIGGGHTS' `compute contact/atom` sums.
    pub contacts_per_particle: f64,
    /// Mean particle–wall contacts per particle at the end (during the last step).
    pub wall_contacts_per_particle: f64,
    /// Memory per particle (bytes): [`model_bytes`] and the backend's scratch buffers on the
    /// CPU; the device buffers on the GPU.
    pub bytes_per_particle: f64,
    /// Worker threads of the rayon pool the steps ran on.
    pub threads: usize,
    /// The plan's per-particle lanes by stage, on the CPU ([`StepPlan::lane_sets`]).
    pub lane_sets: Vec<LaneSet>,
}

/// Runs `warmup` untimed steps, then `steps` timed ones, through [`Simulation::run`] (so
/// neighbour rebuilds and the stability guard are part of the time, as in a real run, and
/// on the GPU the upload before and the download after the steps).
pub fn run(mut sim: Simulation, warmup: u64, steps: u64) -> Result<(BenchReport, Simulation)> {
    let ctl = RunControl::default();
    sim.run(warmup, &ctl, &mut |_| {})?;
    let t0 = Instant::now();
    sim.run(steps, &ctl, &mut |_| {})?;
    let seconds = t0.elapsed().as_secs_f64();
    let lane_sets = sim.plan().lane_sets();
    let m = &sim.model;
    let n = m.len();
    let nf = n.max(1) as f64;
    let wall_contacts: u64 = m.walls.iter().map(|w| u64::from(w.contacts)).sum();
    let report = BenchReport {
        particles: n,
        warmup,
        steps,
        seconds,
        particle_steps_per_s: if seconds > 0.0 { n as f64 * steps as f64 / seconds } else { 0.0 },
        contacts_per_particle: 2.0 * touching_pairs(m) as f64 / nf,
        wall_contacts_per_particle: wall_contacts as f64 / nf,
        bytes_per_particle: if sim.backend_name().starts_with("gpu") {
            sim.backend_bytes() as f64 / nf
        } else {
            (model_bytes(m) + sim.backend_bytes()) as f64 / nf
        },
        threads: crate::backend::CpuBackend::threads(),
        lane_sets,
    };
    Ok((report, sim))
}

/// Where the time of a step goes: each named stage's time in steps run as separate passes.
#[derive(Debug, Clone, PartialEq)]
pub struct StageProfile {
    pub steps: u64,
    /// (stage name, seconds) in step order, the guard last.
    pub stages: Vec<(&'static str, f64)>,
    /// Seconds of the same number of steps run as the fused pass (what an unobserved run does).
    pub fused_seconds: f64,
}

impl StageProfile {
    /// Seconds of the separate passes, all stages.
    pub fn total(&self) -> f64 {
        self.stages.iter().map(|(_, t)| t).sum()
    }
}

/// Profiles `steps` steps of `model` on the CPU backend: first as the fused pass an
/// unobserved run takes (timed whole), then, from the same state, as separate passes, one per
/// named stage, each timed ([`CpuBackend::step_profiled`](crate::backend::CpuBackend)); the
/// guard's checks (`check_state` and the stiffest contact) at the model's guard cadence.
/// The separate passes read the lanes a fused step reads once up to three times, so their
/// sum exceeds the fused time; the shares say which stage's work dominates.
pub fn profile(model: &Model, warmup: u64, steps: u64) -> Result<StageProfile> {
    use crate::backend::CpuBackend;
    use crate::plan::{Stage, StepPlan};
    let mut m = model.clone();
    let mut b = CpuBackend::with_plan(StepPlan::build(&m), StepPlan::build(&m).damping_coefficients(&m));
    let mut sim = Simulation::new(m.clone());
    sim.run(warmup, &RunControl::default(), &mut |_| {})?;
    let t0 = Instant::now();
    sim.run(steps, &RunControl::default(), &mut |_| {})?;
    let fused_seconds = t0.elapsed().as_secs_f64();
    for _ in 0..warmup {
        b.step(&mut m, false);
    }
    let mut times = crate::backend::StageTimes::default();
    let every = m.settings.guard_every.max(1);
    for k in 0..steps {
        b.step_profiled(&mut m, &mut times);
        if (k + 1) % every == 0 {
            let t = Instant::now();
            crate::guard::check_state(&m)?;
            let _ = crate::guard::too_stiff(&m, &b.plan);
            times.add(Stage::Guard, t.elapsed());
        }
    }
    let stages = times.0.iter().map(|(s, t)| (s.name(), t.as_secs_f64())).collect();
    Ok(StageProfile { steps, stages, fused_seconds })
}

/// Profiles `steps` steps of `model` on the GPU `ctx` after `warmup` ordinary ones: each
/// stage in its own pass, timed on the device, then the same number of steps as a run
/// encodes them ([`GpuBackend::profile`](crate::backend::gpu::GpuBackend::profile)).
#[cfg(feature = "gpu")]
pub fn profile_gpu(
    model: &Model,
    ctx: std::sync::Arc<crate::backend::gpu::device::GpuContext>,
    warmup: u64,
    steps: u64,
) -> Result<crate::backend::gpu::profile::GpuProfile> {
    let mut m = model.clone();
    let mut b = crate::backend::gpu::GpuBackend::prepare(ctx, &m)?;
    crate::simulation::run_steps(&mut b, &mut m, warmup, 0, &RunControl::default(), &mut |_| {}, &mut |_| {})?;
    b.profile(&mut m, steps)
}

/// Particle pairs in the rows that touch now (centre distance < r_i + r_j), each once.
pub fn touching_pairs(m: &Model) -> usize {
    let (p, c) = (&m.particles, &m.contacts);
    if c.row_start.len() != p.len() + 1 {
        return 0;
    }
    (0..p.len())
        .map(|i| {
            c.row(i)
                .filter(|&e| {
                    let j = c.other[e] as usize;
                    let touch = p.radius[i] + p.radius[j];
                    i < j && (p.pos[j] - p.pos[i]).norm_squared() < touch * touch
                })
                .count()
        })
        .sum()
}

/// Heap bytes the model holds for its particles (the capacities of the particle lanes,
/// the neighbour rows with their pair state, pair ids, wall masks and build positions, and
/// the wall contact states). Materials, walls, groups and the transient buffers of a rebuild are left out.
pub fn model_bytes(m: &Model) -> usize {
    fn cap<T>(v: &Vec<T>) -> usize {
        v.capacity() * size_of::<T>()
    }
    let p = &m.particles;
    let mut bytes = cap(&p.pos)
        + cap(&p.radius)
        + cap(&p.vel)
        + cap(&p.mass)
        + cap(&p.force)
        + cap(&p.material)
        + cap(&p.fixed)
        + cap(&p.origin);
    if let Some(r) = &p.rotation {
        bytes += cap(&r.ang_vel) + cap(&r.torque) + cap(&r.angle);
    }
    bytes += cap(&p.applied.force) + cap(&p.applied.torque) + cap(&p.applied.offset);
    bytes += p.heat.lanes().iter().map(|l| cap(l)).sum::<usize>();
    // The field stages' lanes (empty unless `bench --field` switched them on).
    bytes += p.thermal.bytes() + m.effects.bytes();
    let c = &m.contacts;
    bytes += cap(&c.row_start) + cap(&c.other) + cap(&c.state) + cap(&c.built_at);
    bytes += cap(&c.pair) + cap(&c.pair_start) + cap(&c.wall_near);
    bytes += m.wall_contacts.capacity() * size_of::<PairState>();
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_scene_keeps_the_aspect() {
        let s = LatticeScene::with_particles(20_000);
        assert_eq!((s.nx, s.ny, s.nz), (20, 20, 50));
        let s = LatticeScene::with_particles(2000);
        assert_eq!((s.nx, s.ny, s.nz), (9, 9, 25));
        assert_eq!(LatticeScene::with_particles(1).particles(), 1);
    }

    // The stirred scene moves: its grains start within ±0.5 m/s a component, not all alike,
    // and 300 steps later the rows have been rebuilt (their build positions moved) while
    // every grain is still inside the box and the guard let the run through.
    #[test]
    fn stirred_lattice_rebuilds_its_rows_as_it_moves() {
        let scene = LatticeScene { nx: 6, ny: 6, nz: 8, ..LatticeScene::default() }.stirred();
        let m = scene.build().unwrap();
        let v = &m.particles.vel;
        assert!(v.iter().all(|w| w.amax() <= 0.5) && v.iter().any(|w| *w != v[0]), "stirred");
        let built = m.contacts.built_at.clone();
        let (_, sim) = run(Simulation::new(m), 0, 300).unwrap();
        let moved = sim.model.contacts.built_at.iter().zip(&built).filter(|(a, b)| a != b).count();
        assert!(moved > 0, "the rows were rebuilt");
        let (lx, lz) = (6.0 * scene.spacing, 8.0 * scene.spacing);
        assert!(sim.model.particles.pos.iter().all(|p| p.x > 0.0 && p.x < lx && p.z > 0.0 && p.z < 2.0 * lz));
    }

    #[test]
    fn standard_lattice_touches_its_six_neighbours_and_the_walls() {
        let scene = LatticeScene { nx: 4, ny: 5, nz: 6, ..LatticeScene::default() };
        let m = scene.build().unwrap();
        // Pairs along x, y and z of a 4 × 5 × 6 block.
        assert_eq!(touching_pairs(&m), 3 * 5 * 6 + 4 * 4 * 6 + 4 * 5 * 5);
        let (report, sim) = run(Simulation::new(m), 2, 3).unwrap();
        assert_eq!(report.particles, 120);
        // Floor 4·5, x sides 2·5·6, y sides 2·4·6.
        let walls: u32 = sim.model.walls.iter().map(|w| w.contacts).sum();
        assert_eq!(walls, 20 + 60 + 48);
        assert!(report.bytes_per_particle > 0.0 && report.particle_steps_per_s > 0.0);
    }
}
