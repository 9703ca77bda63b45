//! Shared helpers for the engine's integration tests: scenes of one or two spheres, a
//! one-step-at-a-time runner that samples an impact, and the closed-form answers of
//! /work/shared/reference/physics.md (§1 Hertz, §2 linear spring–dashpot).
#![allow(dead_code)] // each test file uses its own subset

use matdem_engine::backend::RunControl;
use matdem_engine::simulation::RunReport;
use matdem_engine::{Material, Model, NormalKind, Result, Simulation, Vec3, Wall};
use std::f64::consts::PI;

/// |a − b| / |b|.
pub fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// Mass of a sphere, ρ·4/3·π·r³.
pub fn sphere_mass(density: f64, r: f64) -> f64 {
    density * 4.0 / 3.0 * PI * r.powi(3)
}

/// The density that gives a sphere of radius `r` the mass `m`.
pub fn density_for_mass(m: f64, r: f64) -> f64 {
    m / (4.0 / 3.0 * PI * r.powi(3))
}

/// A material with only the fields a test sets: no bond strength, no friction, no dashpot.
/// `kn` doubles as the linear spring; `young`/`poisson` feed the Hertz law.
pub fn material(name: &str, density: f64, kn: f64, young: f64, poisson: f64) -> Material {
    Material {
        name: name.to_string(),
        density,
        kn,
        ks: 0.0,
        xb: 0.0,
        fs0: 0.0,
        mu_p: 0.0,
        young,
        poisson,
        restitution: 1.0,
        provenance: Default::default(),
    }
}

/// Two spheres of radius `r` on the x axis, `gap` apart (surface to surface), each moving
/// at `speed` towards the other. Particle 0 is on the left.
pub fn two_spheres(mat: Material, r: f64, gap: f64, speed: f64, normal: NormalKind) -> Model {
    let mut m = Model::new();
    m.settings.normal = normal;
    let k = m.add_material(mat).unwrap();
    let a = m.add_particle(Vec3::zeros(), r, k).unwrap();
    let b = m.add_particle(Vec3::new(2.0 * r + gap, 0.0, 0.0), r, k).unwrap();
    m.particles.vel[a] = Vec3::new(speed, 0.0, 0.0);
    m.particles.vel[b] = Vec3::new(-speed, 0.0, 0.0);
    m
}

/// Radius of the spheres of [`damped_glass_pair`] (m).
pub const GLASS_R: f64 = 0.01;

/// Two glass spheres (r 1 cm, E 48 GPa, ν 0.2) 1 µm apart, meeting head-on at 1 m/s each,
/// Hertz with a dashpot for restitution 0.5, at a time step of t_c/200 of the elastic impact.
pub fn damped_glass_pair() -> Model {
    let (young, nu, rho, v) = (4.8e10, 0.2, 2800.0, 1.0);
    let mut mat = material("glass", rho, 1e6, young, nu);
    mat.restitution = 0.5;
    let mut model = two_spheres(mat, GLASS_R, 1e-6, v, NormalKind::Hertz);
    model.set_dt(HertzImpact::two_spheres(young, nu, rho, GLASS_R, v).t_c / 200.0).unwrap();
    model
}

/// A sphere of radius `r` at height `r + gap` above the rigid plane z = 0, falling at `speed`.
pub fn sphere_on_plane(mat: Material, r: f64, gap: f64, speed: f64, normal: NormalKind) -> Model {
    let mut m = Model::new();
    m.settings.normal = normal;
    let k = m.add_material(mat).unwrap();
    m.add_wall(Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
    let a = m.add_particle(Vec3::new(0.0, 0.0, r + gap), r, k).unwrap();
    m.particles.vel[a] = Vec3::new(0.0, 0.0, -speed);
    m
}

/// Runs `steps` steps through the full engine (plan, backend, stability guard).
pub fn run(sim: &mut Simulation, steps: u64) -> Result<RunReport> {
    sim.run(steps, &RunControl::default(), &mut |_| {})
}

/// What a two-body normal impact looks like, as seen by a probe.
#[derive(Debug, Clone, Copy)]
pub struct Probe {
    /// Normal overlap at the current positions (m), > 0 in contact.
    pub overlap: f64,
    /// Magnitude of the contact force of the step just taken (N).
    pub force: f64,
    /// Normal approach speed (m/s), > 0 while the bodies close in.
    pub approach: f64,
}

/// Overlap, force and approach speed of the scene of [`two_spheres`].
pub fn probe_pair(m: &Model) -> Probe {
    let p = &m.particles;
    let d = (p.pos[1] - p.pos[0]).norm();
    Probe { overlap: p.radius[0] + p.radius[1] - d, force: p.force[0].norm(), approach: p.vel[0].x - p.vel[1].x }
}

/// Overlap, force and approach speed of the scene of [`sphere_on_plane`].
pub fn probe_wall(m: &Model) -> Probe {
    let p = &m.particles;
    Probe { overlap: p.radius[0] - p.pos[0].z, force: p.force[0].norm(), approach: -p.vel[0].z }
}

/// A measured impact.
#[derive(Debug, Clone, Copy)]
pub struct Impact {
    /// Approach speed before contact (m/s).
    pub v_in: f64,
    /// Separation speed after contact (m/s); > 0 is a rebound.
    pub v_out: f64,
    /// Largest force seen during contact (N).
    pub peak_force: f64,
    /// Largest overlap seen (m).
    pub max_overlap: f64,
    /// Contact start and end, linearly interpolated between the steps around each crossing
    /// of zero overlap (s); `end` is `None` if the bodies never separated.
    pub start: f64,
    pub end: Option<f64>,
    /// Steps run.
    pub steps: u64,
}

impl Impact {
    pub fn duration(&self) -> f64 {
        self.end.expect("the bodies never separated") - self.start
    }

    pub fn restitution(&self) -> f64 {
        self.v_out / self.v_in
    }
}

/// Runs one step at a time until the bodies have touched and separated again (plus a few
/// steps of free flight) or `max_steps` have run, sampling `probe` after every step.
pub fn run_impact(sim: &mut Simulation, max_steps: u64, probe: fn(&Model) -> Probe) -> Impact {
    let first = probe(&sim.model);
    assert!(first.overlap <= 0.0, "the scene must start apart");
    let mut prev = (sim.model.clock.time, first);
    let mut start = None;
    let mut end = None;
    let (mut peak_force, mut max_overlap) = (0.0f64, f64::NEG_INFINITY);
    let mut after = 0;
    let mut steps = 0;
    while steps < max_steps && after < 10 {
        run(sim, 1).expect("the run must not be stopped by the guard");
        steps += 1;
        let (t, s) = (sim.model.clock.time, probe(&sim.model));
        // Zero-overlap crossing between the previous sample and this one.
        let crossing = || prev.0 + (t - prev.0) * prev.1.overlap / (prev.1.overlap - s.overlap);
        if start.is_none() && s.overlap > 0.0 {
            start = Some(crossing());
        }
        if start.is_some() {
            max_overlap = max_overlap.max(s.overlap);
            // The force lane of this step was computed at the previous positions.
            if prev.1.overlap > 0.0 {
                peak_force = peak_force.max(s.force);
            }
            if end.is_none() && s.overlap <= 0.0 {
                end = Some(crossing());
            }
        }
        if end.is_some() {
            after += 1;
        }
        prev = (t, s);
    }
    Impact {
        v_in: first.approach,
        v_out: -prev.1.approach,
        peak_force,
        max_overlap,
        start: start.expect("the bodies never touched"),
        end,
        steps,
    }
}

/// Elastic Hertz impact (physics.md §1, Johnson 1985 §11.1).
#[derive(Debug, Clone, Copy)]
pub struct HertzImpact {
    pub delta_max: f64,
    pub f_max: f64,
    pub t_c: f64,
}

impl HertzImpact {
    /// From E*, R*, m* and the relative normal speed v.
    pub fn new(e_star: f64, r_star: f64, m_star: f64, v: f64) -> Self {
        let delta_max = (15.0 * m_star * v * v / (16.0 * e_star * r_star.sqrt())).powf(0.4);
        let f_max = 4.0 / 3.0 * e_star * r_star.sqrt() * delta_max.powf(1.5);
        let t_c = 2.868266 * (m_star * m_star / (r_star * e_star * e_star * v)).powf(0.2);
        HertzImpact { delta_max, f_max, t_c }
    }

    /// Two identical spheres of this material, radius `r`, each at `speed` towards the other.
    pub fn two_spheres(young: f64, poisson: f64, density: f64, r: f64, speed: f64) -> Self {
        let e_star = 1.0 / (2.0 * (1.0 - poisson * poisson) / young);
        let m = sphere_mass(density, r);
        Self::new(e_star, r / 2.0, m / 2.0, 2.0 * speed)
    }

    /// A sphere on a rigid wall (R, m, E → ∞ on the wall's side): E* = E/(1 − ν²).
    pub fn sphere_on_wall(young: f64, poisson: f64, density: f64, r: f64, speed: f64) -> Self {
        Self::new(young / (1.0 - poisson * poisson), r, sphere_mass(density, r), speed)
    }
}

/// Linear spring–dashpot impact (physics.md §2).
#[derive(Debug, Clone, Copy)]
pub struct LinearImpact {
    pub zeta: f64,
    pub c: f64,
    pub t_c: f64,
    /// Largest overlap of the undamped impact, v·√(m*/k).
    pub delta_max_undamped: f64,
    /// Largest overlap with the dashpot: x(t) = (v/ωd)·e^(−ζω0·t)·sin(ωd·t) at its
    /// maximum, where tan(ωd·t) = √(1 − ζ²)/ζ.
    pub delta_max: f64,
}

impl LinearImpact {
    /// Spring k, effective mass m*, approach speed v, restitution e.
    pub fn new(k: f64, m_star: f64, v: f64, e: f64) -> Self {
        let l = e.ln();
        let zeta = -l / (PI * PI + l * l).sqrt();
        let c = 2.0 * zeta * (k * m_star).sqrt();
        let omega_0 = (k / m_star).sqrt();
        let omega_d = omega_0 * (1.0 - zeta * zeta).sqrt();
        let t_peak = (1.0 - zeta * zeta).sqrt().atan2(zeta) / omega_d;
        let delta_max = v / omega_d * (-zeta * omega_0 * t_peak).exp() * (omega_d * t_peak).sin();
        LinearImpact { zeta, c, t_c: PI / omega_d, delta_max_undamped: v * (m_star / k).sqrt(), delta_max }
    }
}

/// A GPU device, or `None` (after a note) when there is none and none is required.
#[cfg(feature = "gpu")]
pub fn gpu(test: &str) -> Option<std::sync::Arc<matdem_engine::backend::gpu::device::GpuContext>> {
    use matdem_engine::backend::gpu::device::{select, BackendChoice, Compute};
    let required = std::env::var("MATDEM_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let why = match select(BackendChoice::Gpu) {
        Ok(Compute::Gpu(ctx)) => return Some(ctx),
        Ok(Compute::Cpu { reason }) => reason,
        Err(e) => e.to_string(),
    };
    assert!(!required, "{test}: MATDEM_REQUIRE_GPU=1 but no GPU adapter: {why}");
    eprintln!("{test}: skipped: no GPU adapter ({why})");
    None
}

/// A simple-cubic column of touching spheres (r = a/2, normal stiffness `kn`), nx × nx × nz, its bottom layer held,
/// laterally confined rigidly and without friction (every element's x and y held: walls of
/// finite stiffness let so narrow a column bulge under the pore pressure), with a
/// frictionless top wall that will carry the load. The fluid lives in the network's hull,
/// the box of the element centres, so an element on its side stands for half a column of
/// the ground and one on its edge for a quarter: their stiffness is halved and quartered
/// (materials "edge" and "corner"), so that every column of the skeleton is as stiff as the
/// share of the hull the pore pressure pushes on, and the column deforms in one dimension.
/// The top wall's area is the hull's cross-section, so its stress is the total stress.
pub fn pore_column(nx: usize, nz: usize, a: f64, kn: f64) -> Model {
    let mut m = Model::new();
    let grain =
        |name: &str, w: f64| Material::from_micro(name, 2650.0, w * kn, 0.4 * w * kn, 1e-3, 1e9, 0.5, 0.5 * a).unwrap();
    let mats = [
        m.add_material(grain("grain", 1.0)).unwrap(),
        m.add_material(grain("edge", 0.5)).unwrap(),
        m.add_material(grain("corner", 0.25)).unwrap(),
    ];
    for k in 0..nz {
        for j in 0..nx {
            for i in 0..nx {
                let sides = [i, j].iter().filter(|&&c| c == 0 || c == nx - 1).count();
                m.add_particle(Vec3::new(i as f64, j as f64, k as f64) * a, 0.5 * a, mats[sides]).unwrap();
            }
        }
    }
    confine_column(&mut m, nx, nz, a);
    m
}

/// Makes a simple-cubic column of nx × nx × nz touching spheres at spacing `a` (bottom layer
/// first) a one-dimensional sample: bonds every touching pair, holds the bottom layer, confines
/// the rest laterally, and closes it with a frictionless top wall over the centres'
/// cross-section, with light viscous damping and the standard step.
pub fn confine_column(m: &mut Model, nx: usize, nz: usize, a: f64) {
    use matdem_engine::state::particles::dof;
    let bottom: Vec<u32> = (0..(nx * nx) as u32).collect();
    let all: Vec<u32> = (0..m.len() as u32).collect();
    m.fix(&all, dof::X | dof::Y, true).unwrap();
    m.fix(&bottom, dof::ALL, true).unwrap();
    m.connect(None, 1e-3 * a).unwrap();
    let w = (nx - 1) as f64 * a;
    let h = (nz - 1) as f64 * a;
    let mut top = Wall::plane("top", Vec3::new(0.0, 0.0, h + 0.5 * a), -Vec3::z(), w * w).unwrap();
    top.friction = Some(0.0);
    m.add_wall(top).unwrap();
    m.settings.damping = 0.3;
    m.set_standard_dt().unwrap();
}

/// `m` with each coordinate of every position and velocity moved by up to half an f32 ulp of
/// its own size (relative 2⁻²⁴; the displacement origins moved with the positions, so the twin
/// starts undisplaced as a device's f32 displacements do): a run that starts one rounding away
/// from `m`'s. Like a rounding, the move depends on the value alone (its size and sign from a
/// hash of |x| and `seed`, applied symmetrically about 0), so equal coordinates stay equal and
/// mirror images stay mirror images: a lattice's exact ties and symmetries hold as a device's
/// rounding keeps them, and near-ties may go either way as its rounding may take them.
///
/// A parity test that compares trajectories holds on any device only if its metric stays within
/// its tolerance with such a twin in place of the device: a compiler's choices (fused
/// multiply-adds, reassociation) round otherwise at every step, and what one rounding at the
/// start grows to by the test's horizon, a rounding later can too. Compare the twin's
/// displacements (from its own origins) where the test compares positions.
///
/// It stands for another device where a scene amplifies differences (collisions, slip, ties),
/// not where a test's answer hangs on the start's rounding alone: the start is rounded to f32
/// on the host, alike for every device. A bonded lattice pulled apart breaks its first bond at
/// steps 2,818–2,822 in six twins against the CPU's 2,823, where lavapipe and an H200 each came
/// within a step (`bonded_block_torn_apart_breaks_like_cpu`).
pub fn rounded_twin(mut m: Model, seed: u64) -> Model {
    let nudge = |x: f64| {
        let mut h = x.abs().to_bits() ^ seed.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        // splitmix64's finaliser: every bit of |x| moves the result.
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 31;
        let u = (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
        x * (1.0 + u * f64::powi(2.0, -24))
    };
    let p = &mut m.particles;
    for i in 0..p.pos.len() {
        let moved = p.pos[i].map(nudge);
        p.origin[i] += moved - p.pos[i];
        p.pos[i] = moved;
        p.vel[i] = p.vel[i].map(nudge);
    }
    // A clump's state is its body's: the body one rounding away, its members where it carries them.
    for c in 0..m.clumps.bodies.len() {
        let b = &mut m.clumps.bodies[c];
        (b.pos, b.vel, b.ang_mom) = (b.pos.map(nudge), b.vel.map(nudge), b.ang_mom.map(nudge));
        let before = m.particles.pos.clone();
        matdem_engine::effects::clumps::cpu::place_members(&mut m, c);
        let p = &mut m.particles;
        for i in 0..p.pos.len() {
            p.origin[i] += p.pos[i] - before[i];
        }
    }
    m
}
