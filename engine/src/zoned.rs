//! The zoned builder of paper 001 §1 and §3: concentric cylindrical zones of growing grain
//! size around a fine core (Z1, Z2, …, Zn), with mixing layers (M12, M23, …) between
//! neighbouring zones that hold both sizes at a target porosity, so small grains cannot sink
//! into the pores of large ones. A large model then needs fine grains only where the
//! physics happens (the near field of a cone), and the far field is carried by fewer, larger
//! grains whose materials follow the scaling law (Kn ∝ d, Kn/Ks fixed; see [`crate::scaling`]).
//!
//! How it packs: each region (zone or layer) gets grains drawn until they hold the solid
//! volume that fills its annulus at its target porosity. They are placed at random without
//! overlap while shrunk (random sequential addition at a loose solid fraction, each grain's
//! centre inside its own annulus), then grown back to full size in place, frictionless,
//! inside the closed chamber (bottom, ring and a top platen), as [`crate::training::sample`]
//! packs its samples, and left to settle. While it packs, each grain's centre is held in its
//! own annulus by a soft radial wall (a linear spring with a dashpot on the depth it strays
//! out; `ZoneWalls`), so fine grains cannot sink into the coarse zones' pores: every region
//! jams at once with its own solid fraction, instead of a deposition sorting the sizes. The
//! packing ends by a settling criterion (unbalanced force ratio of the grains inside their
//! annulus under [`PACK_BALANCE_RATIO`], or mean speed under [`SETTLE_SPEED`]) or at its cap
//! ([`PACK_MAX_STEPS`]); [`PackReport`] says which. While packing every size has the finest
//! one's mass per stiffness (mass scaling), so coarse zones settle at the fine grains' pace.
//! A region can hold a porosity only down to what its grains reach when they jam (random close packing, ≈ 0.36 for one size with a
//! 10% spread; lower for two sizes that differ enough for the fine ones to sit in the coarse
//! ones' pores); a region filled denser than that is left overlapping and spreads into its
//! neighbours under load.
//! The model comes back with the grains' real materials, at rest, without gravity: deposit
//! and confine it next.

use crate::backend::RunControl;
use crate::builder::Rng;
use crate::error::{check_positive, Error, Result};
use crate::materials::Material;
use crate::model::Model;
use crate::physics::Vec3;
use crate::scaling::scaled_material;
use crate::simulation::Simulation;
use crate::walls::Wall;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::f64::consts::PI;

/// Paper 001, Table 3: the porosity of the CPT chamber's zones.
pub const PAPER_ZONE_POROSITY: f64 = 0.3545;
/// Paper 001 §3 (group E): the porosity of its mixing layer.
pub const PAPER_MIX_POROSITY: f64 = 0.33;

/// Concentric cylindrical zones about the z axis, from z = 0 to `height`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ZoneSpec {
    /// Outer radius of each zone (m), increasing; the last is the chamber's radius.
    pub radius: Vec<f64>,
    /// Mean grain diameter of each zone (m), not decreasing outwards.
    pub grain_d: Vec<f64>,
    /// Width of the mixing layer at each interface between zone k and k+1 (m), centred on
    /// `radius[k]`; 0 for none. One per interface (`radius.len() − 1` values).
    pub mix: Vec<f64>,
    /// Chamber height (m).
    pub height: f64,
    /// Porosity of the zones.
    pub porosity: f64,
    /// Porosity of the mixing layers.
    pub mix_porosity: f64,
    /// Share of a mixing layer's solid volume in the finer size (0 < share < 1).
    pub mix_fine_share: f64,
    /// Diameters spread uniformly over d·(1 ± distri_rate) (MatDEM's `distriRate`); a small
    /// spread keeps equal spheres from crystallising against the walls.
    pub distri_rate: f64,
    pub seed: u64,
}

impl Default for ZoneSpec {
    fn default() -> Self {
        ZoneSpec {
            radius: Vec::new(),
            grain_d: Vec::new(),
            mix: Vec::new(),
            height: 0.0,
            porosity: PAPER_ZONE_POROSITY,
            mix_porosity: PAPER_MIX_POROSITY,
            mix_fine_share: 0.5,
            distri_rate: 0.1,
            seed: 1,
        }
    }
}

/// One region of a zoned model: a zone (one size) or a mixing layer (two sizes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ZoneRegion {
    /// `zone1`, `zone2`, …, or `mix12`, `mix23`, … (`mix9_10` past nine zones).
    pub name: String,
    /// Inner and outer radius of the annulus (m).
    pub r_in: f64,
    pub r_out: f64,
    /// Target porosity.
    pub porosity: f64,
    /// (size index into `grain_d`, share of the solid volume).
    pub sizes: Vec<(usize, f64)>,
}

impl ZoneRegion {
    pub fn is_mix(&self) -> bool {
        self.sizes.len() > 1
    }
}

/// What one region holds after a build, a deposition or a test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ZoneReport {
    pub name: String,
    pub r_in: f64,
    pub r_out: f64,
    /// Grains whose centre lies in the annulus.
    pub count: usize,
    /// Bulk porosity by volume: the parts of every sphere inside the annulus over its volume,
    /// away from the platens and the ring (see [`zone_report`]).
    pub porosity: f64,
    /// Target porosity.
    pub target_porosity: f64,
    /// Contacts per grain (touching or bonded, any partner), over the grains counted.
    pub coordination: f64,
}

/// The most grains a zoned build makes (as the box builder's cap).
pub const MAX_ZONED_PARTICLES: usize = crate::builder::MAX_BOX_PARTICLES;

/// Width of the empty layer that stands for the looser packing against a wall, in grain
/// diameters: packed beds of spheres in cylinders (Benenati & Brosilow 1962; Jeschar 1975:
/// mean porosity ≈ bulk + 0.22…0.34·d/D) give 0.09…0.14·d.
const WALL_GAP: f64 = 0.12;
/// Solid fraction at which the shrunk grains are placed.
const START_SOLID_FRACTION: f64 = 0.3;
const GROWTH_INCREMENTS: u64 = 40;
const GROWTH_STEPS: u64 = 250;
/// Settling criterion of the frictionless packing: it ends when the unbalanced force ratio
/// of the grains inside their own annulus (the mean of |contact and wall forces| over the
/// mean contact normal force; a grain held by its zone wall is left out, see
/// [`held_unbalanced_ratio`]) falls under this, checked every [`SETTLE_CHECK_EVERY`] steps.
/// 0.05 is MatDEM's usual "balanced" mark. Measured on the CPT's quick chamber
/// (examples/cpt, seeds 1–5, docs/zones-and-scaling.md): A and B–D end by it after
/// 5,000–9,000 settling steps; group E's 1 : 3 mixing layer ends by [`SETTLE_SPEED`].
pub const PACK_BALANCE_RATIO: f64 = 0.05;
/// The packing's cap (after growth): a packing that has not settled by then is returned as
/// it is, its ratio in [`PackReport::unbalanced_ratio`].
pub const PACK_MAX_STEPS: u64 = 20_000;
const SETTLE_CHECK_EVERY: u64 = 100;
/// The kinetic half of the settling criterion: the packing has also settled when its grains'
/// mean speed moves them less than this share of their radius a step (0.3 % of a radius
/// over a check's 100 steps). A packing at the edge of jamming (the zones' 0.3545 is
/// random close packing for a 10 % size spread; a 1 : 3 mixing layer at 0.33) relaxes its
/// last overlaps by slow rearrangement, its unbalanced ratio near 0.1–0.15 for thousands of
/// steps while hardly anything moves; this ends it there (the CPT's group E, ratio 0.12–0.15).
pub const SETTLE_SPEED: f64 = 3e-5;
/// Steps between the zone walls' pushes. The push is the walls' force over this interval
/// given at once (an impulse). MatDEM's standard step is 2π/50 of the stiffest grain's
/// element period, so with the wall at 4× the element stiffness ω·dt ≤ 2·2π/50 and ω·T ≤
/// 0.5, well inside the impulse map's stability limit ω·T < 2 (and the dashpot's impulse
/// 2ζ·ω·T ≤ 0.5 never reverses a grain); a push every step would repeat the run loop's
/// per-chunk checks every step.
const ZONE_WALL_EVERY: u64 = 2;
/// The zone walls' stiffness in the grain's element stiffness (2·Kn for linear contacts).
const ZONE_WALL_STIFFNESS: f64 = 4.0;
/// Damping ratio of the zone walls' dashpot (on the speed into the wall): the walls take
/// energy out of a grain they push back, as local damping does for its contacts.
const ZONE_WALL_DAMPING: f64 = 0.5;

/// How a zoned packing went.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PackReport {
    /// Steps of the growth (fixed: increments × steps per increment).
    pub growth_steps: u64,
    /// Steps of the settling that followed.
    pub settle_steps: u64,
    /// The unbalanced force ratio at the end, zone walls included.
    pub unbalanced_ratio: f64,
    /// The grains' mean speed at the end, in their radii per step.
    pub mean_speed: f64,
    /// Whether the settling criterion (ratio or speed) was met before the cap.
    pub settled: bool,
    /// The deepest any grain's centre lay outside its own annulus at the end, in its radii.
    pub deepest_stray: f64,
}

/// The packing's soft radial walls: each grain's centre is held in its own annulus
/// r_in ≤ ρ ≤ r_out by a repulsive linear spring with a dashpot on the depth it lies
/// outside (k = 4× the grain's element stiffness, 8·Kn for linear contacts: stiff enough
/// that a jammed region's pressure pushes centres out by at most ≈ 2 % of a radius,
/// measured). They act on nothing else, and only while packing: a builder's device, applied
/// between chunks of steps, not a stage of the engine. The core has no inner wall
/// and the outer zone no outer one (the ring holds it). Centres, not surfaces, are held,
/// so neighbouring regions' grains still nest into each other's surface pockets across the
/// boundary instead of each region packing loose against a wall of its own.
struct ZoneWalls {
    /// Per grain: the radial bounds of its centre (m); 0 and ∞ for none.
    bounds: Vec<(f64, f64)>,
}

impl ZoneWalls {
    fn new(grains: &[(usize, usize, f64)], regions: &[ZoneRegion]) -> Self {
        let r_chamber = regions.iter().map(|r| r.r_out).fold(0.0, f64::max);
        let bounds = grains
            .iter()
            .map(|&(g, _, _)| {
                let reg = &regions[g];
                (reg.r_in, if reg.r_out >= r_chamber { f64::INFINITY } else { reg.r_out })
            })
            .collect();
        ZoneWalls { bounds }
    }

    /// Whether any grain has a bound (a one-zone chamber has none: the ring holds it).
    fn any(&self) -> bool {
        self.bounds.iter().any(|&(lo, hi)| lo > 0.0 || hi.is_finite())
    }

    /// The outward normal of the bound grain `i` has crossed and the depth past it (m), or
    /// `None` inside its annulus.
    fn crossing(&self, i: usize, x: &Vec3) -> Option<(Vec3, f64)> {
        let (lo, hi) = self.bounds[i];
        let rho = (x.x * x.x + x.y * x.y).sqrt();
        let out = if rho > 0.0 { Vec3::new(x.x / rho, x.y / rho, 0.0) } else { Vec3::x() };
        if rho > hi {
            Some((out, rho - hi))
        } else if rho < lo {
            Some((-out, lo - rho))
        } else {
            None
        }
    }

    /// Gives every grain outside its annulus the impulse of its wall over `interval` (s):
    /// spring and dashpot, never pulling.
    fn push(&self, m: &mut Model, interval: f64) {
        for i in 0..m.len() {
            let Some((n, depth)) = self.crossing(i, &m.particles.pos[i]) else { continue };
            let (k, mass) = (ZONE_WALL_STIFFNESS * m.element_stiffness(i), m.particles.mass[i]);
            let c = 2.0 * ZONE_WALL_DAMPING * (k * mass).sqrt();
            let v = m.particles.vel[i];
            let f = (k * depth + c * v.dot(&n)).max(0.0);
            m.particles.vel[i] = v - n * (f * interval / mass);
        }
    }

    /// The deepest any grain's centre lies outside its annulus, in its radii.
    fn deepest(&self, m: &Model) -> f64 {
        let p = &m.particles;
        (0..p.len()).filter_map(|i| self.crossing(i, &p.pos[i]).map(|(_, d)| d / p.radius[i])).fold(0.0, f64::max)
    }
}

/// The grains' mean speed in their radii per step.
fn mean_speed(m: &Model) -> f64 {
    let p = &m.particles;
    let dt = m.clock.dt;
    (0..p.len()).map(|i| p.vel[i].norm() * dt / p.radius[i]).sum::<f64>() / p.len().max(1) as f64
}

/// Runs `steps` steps with the zone walls pushing every [`ZONE_WALL_EVERY`] steps (in one
/// run when no grain has a zone wall: chunks change no result, only the run's overhead).
fn run_held(sim: &mut Simulation, walls: &ZoneWalls, steps: u64, ctl: &RunControl) -> Result<()> {
    if !walls.any() {
        sim.run(steps, ctl, &mut |_| {})?;
        return Ok(());
    }
    let mut done = 0;
    while done < steps {
        let chunk = ZONE_WALL_EVERY.min(steps - done);
        sim.run(chunk, ctl, &mut |_| {})?;
        let interval = chunk as f64 * sim.model.clock.dt;
        walls.push(&mut sim.model, interval);
        done += chunk;
    }
    Ok(())
}

/// The unbalanced force ratio of the grains inside their own annulus: the mean over them of
/// |contact and wall forces (of the last step)| over the mean contact normal force (as
/// [`crate::status::contact_stats`]). A grain held by its zone wall is left out: the wall
/// holds it with impulses between steps, and Cundall's local damping (−α·|F|·sign v) does
/// not see the wall: in the orbit of two steps and a push that a held grain comes to rest
/// in, its velocity is against the contact force F at both steps, so the damping adds α·F
/// = 0.7·F to it and the wall gives 1.7·F (the orbit's fixed point, derived): at rest, it
/// still looks unbalanced by 0.7·F. Counted, the ≈ 100 held grains of the CPT's group B (5 %
/// of its grains) looked unbalanced by 0.5 of a mean contact force each, which alone kept the
/// ratio at 0.03 however still the packing was (measured). Whether they move, the mean
/// speed says.
fn held_unbalanced_ratio(sim: &mut Simulation, walls: &ZoneWalls) -> f64 {
    let mean_normal = sim.contact_stats().mean_normal_force;
    let m = &sim.model;
    let g = m.settings.gravity;
    let p = &m.particles;
    let inner: Vec<usize> = (0..p.len()).filter(|&i| m.is_free(i) && walls.crossing(i, &p.pos[i]).is_none()).collect();
    let net: f64 = inner.iter().map(|&i| (p.force[i] + g * p.mass[i]).norm()).sum::<f64>() / inner.len().max(1) as f64;
    if mean_normal > 0.0 {
        net / mean_normal
    } else if net > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

impl ZoneSpec {
    /// Refuses what cannot be built, saying what to give instead.
    pub fn validate(&self) -> Result<()> {
        let n = self.radius.len();
        if n == 0 {
            return Err(Error::InvalidScene(
                "a zoned model needs at least one zone: set radius = [r1, r2, …] (outer radius of each zone, m) \
                 and grain_d = [d1, d2, …] (grain diameter of each zone, m)"
                    .into(),
            ));
        }
        if self.grain_d.len() != n {
            return Err(Error::InvalidScene(format!(
                "radius has {n} zone(s) but grain_d has {} diameter(s): give one grain diameter per zone",
                self.grain_d.len()
            )));
        }
        if !(self.mix.is_empty() || self.mix.len() + 1 == n) {
            return Err(Error::InvalidScene(format!(
                "mix has {} width(s) for {} interface(s): give one mixing-layer width per interface between \
                 neighbouring zones (0 for none), or leave mix empty",
                self.mix.len(),
                n - 1
            )));
        }
        check_positive("height", self.height, false)?;
        for (k, &r) in self.radius.iter().enumerate() {
            check_positive("radius", r, false).map_err(|e| Error::InvalidScene(format!("zone {}: {e}", k + 1)))?;
            if k > 0 && r <= self.radius[k - 1] {
                return Err(Error::InvalidScene(format!(
                    "zone radii must increase outwards (each is a zone's outer radius): radius[{}] = {r} is not \
                     larger than radius[{}] = {}",
                    k,
                    k - 1,
                    self.radius[k - 1]
                )));
            }
        }
        for (k, &d) in self.grain_d.iter().enumerate() {
            check_positive("grain_d", d, false).map_err(|e| Error::InvalidScene(format!("zone {}: {e}", k + 1)))?;
            if k > 0 && d < self.grain_d[k - 1] {
                return Err(Error::InvalidScene(format!(
                    "grain sizes must not shrink outwards (fine core, coarser rings): grain_d[{}] = {d} is smaller \
                     than grain_d[{}] = {}; sort the zones from the core out",
                    k,
                    k - 1,
                    self.grain_d[k - 1]
                )));
            }
        }
        for (k, &w) in self.mix.iter().enumerate() {
            check_positive("mix", w, true)
                .map_err(|e| Error::InvalidScene(format!("mixing layer {}{}: {e}", k + 1, k + 2)))?;
            if w > 0.0 && w < self.grain_d[k + 1] {
                return Err(Error::InvalidScene(format!(
                    "mixing layer {}{} is {w} m wide, narrower than one coarse grain ({} m): make it at least \
                     that wide (the paper's is about two coarse grains) or 0 for none",
                    k + 1,
                    k + 2,
                    self.grain_d[k + 1]
                )));
            }
        }
        for (name, v) in [("porosity", self.porosity), ("mix_porosity", self.mix_porosity)] {
            if !(v.is_finite() && (0.2..0.7).contains(&v)) {
                return Err(Error::param(
                    if name == "porosity" { "porosity" } else { "mix_porosity" },
                    v,
                    "a packed granular zone has a porosity in [0.2, 0.7) (paper 001: 0.3545, mixing layer 0.33)",
                ));
            }
        }
        if !(self.mix_fine_share.is_finite() && self.mix_fine_share > 0.0 && self.mix_fine_share < 1.0) {
            return Err(Error::param(
                "mix_fine_share",
                self.mix_fine_share,
                "the finer size's share of a mixing layer's solid volume must be between 0 and 1 (0.5: equal volumes)",
            ));
        }
        if !(self.distri_rate.is_finite() && (0.0..0.5).contains(&self.distri_rate)) {
            return Err(Error::param("distri_rate", self.distri_rate, "must be in [0, 0.5)"));
        }
        // Each zone keeps at least one of its grains' width beside its mixing layers.
        for region in self.regions() {
            let d = region.sizes.iter().map(|&(k, _)| self.grain_d[k]).fold(0.0, f64::max);
            let width = region.r_out - region.r_in;
            if !region.is_mix() && width < d {
                let k: usize = region.name[4..].parse().unwrap_or(1);
                return Err(Error::InvalidScene(format!(
                    "zone {k} keeps only {width:.4} m between its mixing layers, less than one of its grains \
                     ({d} m): narrow the mixing layers beside it (each takes half its width from each neighbour) \
                     or widen the zone"
                )));
            }
        }
        if self.height < self.grain_d[n - 1] * 2.0 {
            return Err(Error::InvalidScene(format!(
                "height {} m holds fewer than two of the coarsest grains ({} m): make the chamber taller",
                self.height,
                self.grain_d[n - 1]
            )));
        }
        let total: f64 = self.counts().iter().map(|(_, c)| c.iter().map(|&(_, n)| n as f64).sum::<f64>()).sum();
        if total > MAX_ZONED_PARTICLES as f64 {
            return Err(Error::InvalidScene(format!(
                "the zoned model would hold about {total:.3e} grains, more than the {MAX_ZONED_PARTICLES} a build \
                 may make: use larger grains or a smaller chamber"
            )));
        }
        Ok(())
    }

    /// Zones and mixing layers from the core out.
    pub fn regions(&self) -> Vec<ZoneRegion> {
        let n = self.radius.len();
        let half = |k: usize| if k + 1 < n { 0.5 * self.mix.get(k).copied().unwrap_or(0.0) } else { 0.0 };
        let mut out = Vec::new();
        for k in 0..n {
            let r_in = if k == 0 { 0.0 } else { self.radius[k - 1] + half(k - 1) };
            let r_out = self.radius[k] - half(k);
            out.push(ZoneRegion {
                name: format!("zone{}", k + 1),
                r_in,
                r_out,
                porosity: self.porosity,
                sizes: vec![(k, 1.0)],
            });
            if half(k) > 0.0 {
                let name = if n > 9 { format!("mix{}_{}", k + 1, k + 2) } else { format!("mix{}{}", k + 1, k + 2) };
                out.push(ZoneRegion {
                    name,
                    r_in: self.radius[k] - half(k),
                    r_out: self.radius[k] + half(k),
                    porosity: self.mix_porosity,
                    sizes: vec![(k, self.mix_fine_share), (k + 1, 1.0 - self.mix_fine_share)],
                });
            }
        }
        out
    }

    /// Mean volume of a grain of size `k` (diameter uniform in d·(1 ± distri_rate)).
    fn grain_volume(&self, k: usize) -> f64 {
        let (a, b) =
            (0.5 * self.grain_d[k] * (1.0 - self.distri_rate), 0.5 * self.grain_d[k] * (1.0 + self.distri_rate));
        if b > a {
            PI / 3.0 * (b.powi(4) - a.powi(4)) / (b - a)
        } else {
            4.0 / 3.0 * PI * a.powi(3)
        }
    }

    /// Solid volume per region and size: (region, [(size, m³)]), filling each annulus at its
    /// target porosity.
    pub fn solids(&self) -> Vec<(ZoneRegion, Vec<(usize, f64)>)> {
        self.regions()
            .into_iter()
            .map(|reg| {
                // The packing is looser against a wall in every random packing; the bulk
                // reaches the target when each wall takes a layer WALL_GAP·d wide out of the
                // volume to fill (bottom, top platen, and the ring for the outer zone). In a
                // mixing layer d is its sizes' geometric mean weighted by volume share: the
                // fine grains fill part of the coarse ones' pockets at the wall. Measured on the
                // CPT's group E (6 + 18 mm, 54 mm high, five seeds): the layer's bulk was
                // 0.03 denser than its whole height, a gap of 1.2 mm a platen, 0.12 × 10 mm;
                // the fine size's gap left it 0.012 too dense, the mean diameter's 0.02 too loose.
                let d = reg.sizes.iter().map(|&(k, share)| share * self.grain_d[k].ln()).sum::<f64>().exp();
                let gap = WALL_GAP * d;
                let area = PI * (reg.r_out.powi(2) - reg.r_in.powi(2));
                let outer = reg.r_out >= self.radius[self.radius.len() - 1];
                let ring = if outer { 2.0 * PI * reg.r_out * self.height } else { 0.0 };
                let volume = (area * (self.height - 2.0 * gap) - ring * gap).max(0.0);
                let solid = volume * (1.0 - reg.porosity);
                let v = reg.sizes.iter().map(|&(k, share)| (k, solid * share)).collect();
                (reg, v)
            })
            .collect()
    }

    /// Grains per region and size expected: (region, [(size, count)]), the solid volume over
    /// the mean grain volume (the build draws sizes until it has the volume, so its counts
    /// differ from these by the draw's scatter).
    pub fn counts(&self) -> Vec<(ZoneRegion, Vec<(usize, usize)>)> {
        self.solids()
            .into_iter()
            .map(|(reg, v)| {
                let c = v.iter().map(|&(k, vol)| (k, (vol / self.grain_volume(k)).round().max(1.0) as usize)).collect();
                (reg, c)
            })
            .collect()
    }

    /// Packs the zones. `material` is the finest grains' material (zone 1's size); with
    /// `scale_stiffness` every coarser size gets it scaled by d/d1 by the scaling law
    /// (materials `NAME_zone1`, `NAME_zone2`, …), else all sizes share it unchanged.
    /// Groups: `zone1…`, `mix12…`, `sample` (all); walls `bottom`, `ring`, `top_platen`.
    pub fn build(
        &self,
        material: &Material,
        scale_stiffness: bool,
        ctl: &RunControl,
    ) -> Result<(Model, Vec<ZoneRegion>)> {
        self.pack(material, scale_stiffness, ctl).map(|(model, regions, _)| (model, regions))
    }

    /// As [`build`](Self::build), also saying how the packing went: its steps, whether it
    /// settled before its cap, and how far any grain ended outside its annulus.
    pub fn pack(
        &self,
        material: &Material,
        scale_stiffness: bool,
        ctl: &RunControl,
    ) -> Result<(Model, Vec<ZoneRegion>, PackReport)> {
        self.validate()?;
        let counts = self.counts();
        let total: usize = counts.iter().map(|(_, c)| c.iter().map(|&(_, n)| n).sum::<usize>()).sum();
        crate::memory_budget::check_fits(
            "the zoned model",
            total as u64,
            crate::memory_budget::CPU_BYTES_PER_PARTICLE,
        )?;
        let n = self.radius.len();
        let r_chamber = self.radius[n - 1];
        // Materials per size: the law from the finest, or one shared material.
        let mut materials = Vec::with_capacity(n);
        for k in 0..n {
            let mut m = if scale_stiffness {
                scaled_material(material, self.grain_d[k] / self.grain_d[0])?
            } else {
                material.clone()
            };
            m.name = format!("{}_zone{}", material.name, k + 1);
            materials.push(m);
        }
        // Frictionless, unbonded twins for the packing, their densities scaled so that every
        // size's grain has the finest one's mass per stiffness (its period, see
        // [`packing_density_factor`]).
        let mut model = Model::new();
        for (k, m) in materials.iter().enumerate() {
            let mut p = m.clone();
            p.mu_p = 0.0;
            p.fs0 = 0.0;
            p.xb = 0.0;
            p.density *= packing_density_factor(&materials, &self.grain_d, k);
            model.add_material(p)?;
        }
        // Grains drawn per region and size until they hold its solid volume (the one that
        // would overshoot by more than half its own volume is left out): a count would let
        // a few coarse grains' random sizes move a mixing layer's porosity by 0.02 or more.
        // Then largest first: random sequential addition places big ones far more easily.
        let mut rng = Rng::new(self.seed);
        let mut grains: Vec<(usize, usize, f64)> = Vec::with_capacity(total); // (region, size, radius)
        for (g, (_, v)) in self.solids().iter().enumerate() {
            for &(k, solid) in v {
                let mut filled = 0.0;
                let mut n = 0;
                loop {
                    let r = 0.5 * self.grain_d[k] * (1.0 + self.distri_rate * (2.0 * rng.uniform() - 1.0));
                    let vol = 4.0 / 3.0 * PI * r * r * r;
                    if n > 0 && filled + 0.5 * vol > solid {
                        break;
                    }
                    grains.push((g, k, r));
                    filled += vol;
                    n += 1;
                }
            }
        }
        grains.sort_by(|a, b| b.2.total_cmp(&a.2));
        let full_solid = 1.0 - self.porosity.min(self.mix_porosity);
        let shrink = (START_SOLID_FRACTION / full_solid).cbrt().min(1.0);
        let regions: Vec<ZoneRegion> = counts.iter().map(|(r, _)| r.clone()).collect();
        let placed = place_shrunk(&grains, &regions, r_chamber, self.height, shrink, &mut rng, ctl)?;
        let (grains, placed) = in_id_order(grains, placed, shrink);
        let mut group_ids: Vec<Vec<u32>> = vec![Vec::new(); regions.len()];
        for (x, &(g, k, r)) in placed.iter().zip(&grains) {
            let id = model.add_particle(*x, r * shrink, k as u32)?;
            group_ids[g].push(id as u32);
        }
        let area = PI * r_chamber * r_chamber;
        model.add_wall(Wall::plane("bottom", Vec3::zeros(), Vec3::z(), area)?)?;
        model.add_wall(Wall::cylinder("ring", Vec3::zeros(), r_chamber, 2.0 * PI * r_chamber * self.height)?)?;
        model.add_wall(Wall::plane("top_platen", Vec3::new(0.0, 0.0, self.height), -Vec3::z(), area)?)?;
        model.settings.local_damping = 0.7;
        model.set_standard_dt()?;
        let full: Vec<f64> = grains.iter().map(|g| g.2).collect();
        let walls = ZoneWalls::new(&grains, &regions);
        let mut sim = Simulation::new(model);
        for step in 1..=GROWTH_INCREMENTS {
            let f = shrink + (1.0 - shrink) * step as f64 / GROWTH_INCREMENTS as f64;
            let m = &mut sim.model;
            for (i, r_full) in full.iter().enumerate() {
                let r = r_full * f;
                let density = m.materials[m.particles.material[i] as usize].density;
                m.particles.radius[i] = r;
                m.particles.mass[i] = density * 4.0 / 3.0 * PI * r * r * r;
            }
            m.contacts.stale = true;
            run_held(&mut sim, &walls, GROWTH_STEPS, ctl)?;
        }
        let mut report = PackReport {
            growth_steps: GROWTH_INCREMENTS * GROWTH_STEPS,
            settle_steps: 0,
            unbalanced_ratio: f64::INFINITY,
            mean_speed: f64::INFINITY,
            settled: false,
            deepest_stray: 0.0,
        };
        while report.settle_steps < PACK_MAX_STEPS {
            run_held(&mut sim, &walls, SETTLE_CHECK_EVERY, ctl)?;
            report.settle_steps += SETTLE_CHECK_EVERY;
            report.unbalanced_ratio = held_unbalanced_ratio(&mut sim, &walls);
            report.mean_speed = mean_speed(&sim.model);
            if report.unbalanced_ratio < PACK_BALANCE_RATIO || report.mean_speed < SETTLE_SPEED {
                report.settled = true;
                break;
            }
        }
        report.deepest_stray = walls.deepest(&sim.model);
        let mut model = sim.model;
        // The real materials (same order, so the particles' indices hold), at rest.
        model.materials.clear();
        for m in materials {
            model.add_material(m)?;
        }
        for i in 0..model.len() {
            let mat = model.particles.material[i] as usize;
            let r = model.particles.radius[i];
            model.particles.mass[i] = model.materials[mat].density * 4.0 / 3.0 * PI * r * r * r;
        }
        for v in &mut model.particles.vel {
            *v = Vec3::zeros();
        }
        for s in model.contacts.state.iter_mut().chain(model.wall_contacts.iter_mut()) {
            s.shear = Vec3::zeros();
        }
        model.particles.origin = model.particles.pos.clone();
        model.settings.local_damping = 0.0;
        model.set_standard_dt()?;
        model.groups.set("sample", (0..model.len() as u32).collect());
        for (reg, ids) in regions.iter().zip(group_ids) {
            model.groups.set(&reg.name, ids);
        }
        Ok((model, regions, report))
    }
}

/// The packing's density of size `k` over its real one: the grain of mean diameter `d_k`
/// gets the finest size's mass per unit of element stiffness, so every size has the finest
/// one's period and the packing relaxes everywhere at the pace of the fine grains, which
/// set the time step (mass scaling: a frictionless packing's end state is an equilibrium,
/// which masses do not change; only the path to it). With their real masses the coarse
/// grains of equal Kn (the CPT's groups B and C, 12 mm beside 6 mm) have 2.8× the period and
/// took 17,000 steps to the cap of settling where the fine chamber A took 6,400–8,900
/// (docs/zones-and-scaling.md). The real densities come back when the packing ends.
fn packing_density_factor(materials: &[Material], grain_d: &[f64], k: usize) -> f64 {
    let mass_per_stiffness = |k: usize| materials[k].density * grain_d[k].powi(3) / materials[k].kn;
    let f = mass_per_stiffness(0) / mass_per_stiffness(k);
    if f.is_finite() && f > 0.0 {
        f
    } else {
        1.0
    }
}

/// The grains and their places in the order they get their ids (`space_filling::id_order`: a
/// large chamber's in Z-order, a small one's as placed, largest first).
fn in_id_order(
    grains: Vec<(usize, usize, f64)>,
    placed: Vec<Vec3>,
    shrink: f64,
) -> (Vec<(usize, usize, f64)>, Vec<Vec3>) {
    let mean_d = 2.0 * shrink * grains.iter().map(|g| g.2).sum::<f64>() / grains.len().max(1) as f64;
    let order = crate::space_filling::id_order(&placed, mean_d);
    (order.iter().map(|&k| grains[k]).collect(), order.iter().map(|&k| placed[k]).collect())
}

/// Random sequential addition of shrunk grains, each with its centre in its own annulus,
/// whole inside the chamber.
fn place_shrunk(
    grains: &[(usize, usize, f64)],
    regions: &[ZoneRegion],
    r_chamber: f64,
    height: f64,
    shrink: f64,
    rng: &mut Rng,
    ctl: &RunControl,
) -> Result<Vec<Vec3>> {
    let r_max = grains.iter().map(|g| g.2 * shrink).fold(0.0, f64::max);
    let h = 2.0 * r_max;
    let cell = |v: &Vec3| (((v.x + r_chamber) / h) as i64, ((v.y + r_chamber) / h) as i64, (v.z / h) as i64);
    let mut cells: HashMap<(i64, i64, i64), Vec<u32>> = HashMap::new();
    let mut placed: Vec<Vec3> = Vec::with_capacity(grains.len());
    for (k, &(g, _, r_full)) in grains.iter().enumerate() {
        if k % 1024 == 0 && ctl.is_cancelled() {
            return Err(Error::Cancelled { completed_steps: 0 });
        }
        let r = r_full * shrink;
        let reg = &regions[g];
        let rho_lo = reg.r_in;
        let rho_hi = reg.r_out.min(r_chamber - r);
        if rho_hi < rho_lo || height < 2.0 * r {
            return Err(Error::InvalidScene(format!(
                "region {} has no room for its grains: widen it or use smaller grains",
                reg.name
            )));
        }
        let mut tries = 0u32;
        let pos = loop {
            tries += 1;
            if tries > 200_000 {
                return Err(Error::InvalidScene(format!(
                    "could not place grain {k} (radius {r_full}) in {}: the region is too small or too crowded \
                     for its porosity; widen it or raise its porosity",
                    reg.name
                )));
            }
            // Uniform over the annulus's area.
            let rho = (rho_lo * rho_lo + (rho_hi * rho_hi - rho_lo * rho_lo) * rng.uniform()).sqrt();
            let theta = 2.0 * PI * rng.uniform();
            let z = r + (height - 2.0 * r) * rng.uniform();
            let c = Vec3::new(rho * theta.cos(), rho * theta.sin(), z);
            let (cx, cy, cz) = cell(&c);
            let mut free = true;
            'search: for iz in cz - 1..=cz + 1 {
                for iy in cy - 1..=cy + 1 {
                    for ix in cx - 1..=cx + 1 {
                        for &j in cells.get(&(ix, iy, iz)).map(|v| v.as_slice()).unwrap_or(&[]) {
                            let rj = grains[j as usize].2 * shrink;
                            if (placed[j as usize] - c).norm() < r + rj {
                                free = false;
                                break 'search;
                            }
                        }
                    }
                }
            }
            if free {
                cells.entry((cx, cy, cz)).or_default().push(k as u32);
                break c;
            }
        };
        placed.push(pos);
    }
    Ok(placed)
}

/// Area of a disc of radius `a` whose centre is `rho` from the centre of a circle of
/// radius `big`, inside that circle (the lens of two circles).
fn disc_in_circle(a: f64, rho: f64, big: f64) -> f64 {
    if big <= 0.0 || a <= 0.0 {
        return 0.0;
    }
    if rho + a <= big {
        return PI * a * a;
    }
    if rho >= big + a {
        return 0.0;
    }
    if rho + big <= a {
        return PI * big * big;
    }
    let c1 = ((rho * rho + a * a - big * big) / (2.0 * rho * a)).clamp(-1.0, 1.0);
    let c2 = ((rho * rho + big * big - a * a) / (2.0 * rho * big)).clamp(-1.0, 1.0);
    let k = ((-rho + a + big) * (rho + a - big) * (rho - a + big) * (rho + a + big)).max(0.0);
    a * a * c1.acos() + big * big * c2.acos() - 0.5 * k.sqrt()
}

/// Volume of the sphere (centre `x`, radius `r`) inside the annulus r_in ≤ ρ ≤ r_out about
/// the vertical axis through `axis`, between `z0` and `z1`: exact when the sphere lies
/// wholly inside or outside, else integrated over horizontal slices (each slice a disc, its
/// part in the annulus a difference of two lens areas) by composite Gauss–Legendre, which
/// is good to ~1e-7 of the sphere's volume.
pub fn sphere_in_annulus(x: &Vec3, r: f64, axis: &Vec3, r_in: f64, r_out: f64, z0: f64, z1: f64) -> f64 {
    let rho = ((x.x - axis.x).powi(2) + (x.y - axis.y).powi(2)).sqrt();
    let (lo, hi) = ((x.z - r).max(z0), (x.z + r).min(z1));
    if hi <= lo || rho - r >= r_out || rho + r <= r_in {
        return 0.0;
    }
    if rho - r >= r_in && rho + r <= r_out && x.z - r >= z0 && x.z + r <= z1 {
        return 4.0 / 3.0 * PI * r * r * r;
    }
    // The slice area has kinks where a slice's rim touches a circle of the annulus (its
    // radius a = |R − ρ| or R + ρ): split there, and map each piece by z = lo + (hi − lo)·(1 −
    // cos πt)/2, which smooths the square-root behaviour at both ends; then 4-point
    // Gauss–Legendre on 8 sub-intervals of t per piece.
    const NODES: [(f64, f64); 4] = [
        (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    ];
    let mut cuts = vec![lo, hi];
    for big in [r_in, r_out] {
        for a in [(big - rho).abs(), big + rho] {
            if a < r {
                let dz = (r * r - a * a).sqrt();
                cuts.extend([x.z - dz, x.z + dz].into_iter().filter(|&z| z > lo && z < hi));
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    let slice = |z: f64| {
        let a = (r * r - (z - x.z).powi(2)).max(0.0).sqrt();
        disc_in_circle(a, rho, r_out) - disc_in_circle(a, rho, r_in)
    };
    let parts = 8;
    let mut v = 0.0;
    for piece in cuts.windows(2) {
        let (a, b) = (piece[0], piece[1]);
        if b <= a {
            continue;
        }
        let w = 1.0 / parts as f64;
        for p in 0..parts {
            let mid = (p as f64 + 0.5) * w;
            for (t, wt) in NODES {
                let t = mid + 0.5 * w * t;
                let z = a + (b - a) * 0.5 * (1.0 - (PI * t).cos());
                let dz_dt = (b - a) * 0.5 * PI * (PI * t).sin();
                v += 0.5 * w * wt * slice(z) * dz_dt;
            }
        }
    }
    v
}

/// Porosity of the annulus r_in ≤ ρ ≤ r_out about the z axis through `axis`, between `z0`
/// and `z1`, counting the part of every sphere inside it.
pub fn annulus_porosity(m: &Model, axis: &Vec3, r_in: f64, r_out: f64, z0: f64, z1: f64) -> f64 {
    let v = PI * (r_out * r_out - r_in * r_in) * (z1 - z0);
    if v <= 0.0 {
        return f64::NAN;
    }
    let p = &m.particles;
    let solid: f64 = (0..p.len()).map(|i| sphere_in_annulus(&p.pos[i], p.radius[i], axis, r_in, r_out, z0, z1)).sum();
    1.0 - solid / v
}

/// Count, porosity and coordination of each region. The porosity is the bulk's: between
/// one coarsest grain above the lowest sphere bottom and one below the highest sphere top,
/// and, for the outer zone, one of its grains inside the ring, since every random packing
/// is looser against a wall (the builder allows for that).
pub fn zone_report(m: &Model, regions: &[ZoneRegion], grain_d: &[f64]) -> Vec<ZoneReport> {
    let p = &m.particles;
    let d_max = grain_d.iter().copied().fold(0.0, f64::max);
    let z0 = (0..p.len()).map(|i| p.pos[i].z - p.radius[i]).fold(f64::INFINITY, f64::min) + d_max;
    let z1 = (0..p.len()).map(|i| p.pos[i].z + p.radius[i]).fold(f64::NEG_INFINITY, f64::max) - d_max;
    let r_chamber = regions.iter().map(|r| r.r_out).fold(0.0, f64::max);
    let c = &m.contacts;
    let built = c.row_start.len() == p.len() + 1;
    let contacts_of = |i: usize| -> usize {
        if !built {
            return 0;
        }
        c.row(i)
            .filter(|&e| {
                let j = c.other[e] as usize;
                c.state[e].bonded || (p.pos[j] - p.pos[i]).norm() < p.radius[i] + p.radius[j]
            })
            .count()
    };
    let axis = Vec3::zeros();
    regions
        .iter()
        .map(|reg| {
            let ids: Vec<usize> = (0..p.len())
                .filter(|&i| {
                    let rho = (p.pos[i].x.powi(2) + p.pos[i].y.powi(2)).sqrt();
                    rho >= reg.r_in && rho < reg.r_out
                })
                .collect();
            let links: usize = ids.iter().map(|&i| contacts_of(i)).sum();
            let d = reg.sizes.iter().map(|&(k, _)| grain_d.get(k).copied().unwrap_or(0.0)).fold(0.0, f64::max);
            let r_out = if reg.r_out >= r_chamber { (reg.r_out - d).max(reg.r_in) } else { reg.r_out };
            let porosity =
                if p.is_empty() || z1 <= z0 { f64::NAN } else { annulus_porosity(m, &axis, reg.r_in, r_out, z0, z1) };
            ZoneReport {
                name: reg.name.clone(),
                r_in: reg.r_in,
                r_out: reg.r_out,
                count: ids.len(),
                porosity,
                target_porosity: reg.porosity,
                coordination: if ids.is_empty() { 0.0 } else { links as f64 / ids.len() as f64 },
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_volume_in_annuli_adds_up_and_matches_the_cylinder_formula() {
        let (r, x) = (1.0, Vec3::new(0.7, 0.2, 0.0));
        let full = 4.0 / 3.0 * PI;
        let rho = (0.7f64 * 0.7 + 0.2 * 0.2).sqrt();
        let parts = sphere_in_annulus(&x, r, &Vec3::zeros(), 0.0, rho, -5.0, 5.0)
            + sphere_in_annulus(&x, r, &Vec3::zeros(), rho, 0.4 + rho, -5.0, 5.0)
            + sphere_in_annulus(&x, r, &Vec3::zeros(), 0.4 + rho, 10.0, -5.0, 5.0);
        assert!((parts / full - 1.0).abs() < 1e-7, "{parts} vs {full}");
        // A cylinder of radius a through the centre of a sphere: V = 4π/3·(r³ − (r² − a²)^(3/2)).
        let a = 0.6;
        let v = sphere_in_annulus(&Vec3::zeros(), r, &Vec3::zeros(), 0.0, a, -5.0, 5.0);
        let exact = 4.0 * PI / 3.0 * (1.0 - (1.0f64 - a * a).powf(1.5));
        assert!((v / exact - 1.0).abs() < 1e-7, "{v} vs {exact}");
        // Cut by a horizontal plane through the centre: half.
        let half = sphere_in_annulus(&Vec3::zeros(), r, &Vec3::zeros(), 0.0, 5.0, 0.0, 5.0);
        assert!((half / (0.5 * full) - 1.0).abs() < 1e-9);
    }

    fn spec() -> ZoneSpec {
        ZoneSpec {
            radius: vec![0.075, 0.095, 0.15],
            grain_d: vec![6e-3, 9e-3, 12e-3],
            mix: vec![0.0, 0.02],
            height: 0.3,
            ..ZoneSpec::default()
        }
    }

    #[test]
    fn regions_follow_radii_and_mixing_layers() {
        let regs = spec().regions();
        let names: Vec<&str> = regs.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, ["zone1", "zone2", "mix23", "zone3"]);
        assert_eq!((regs[1].r_in, regs[1].r_out), (0.075, 0.085));
        assert_eq!((regs[2].r_in, regs[2].r_out), (0.085, 0.105));
        assert_eq!(regs[2].sizes, vec![(1, 0.5), (2, 0.5)]);
        assert!(spec().validate().is_ok());
    }

    #[test]
    fn bad_zones_are_refused_with_what_to_do() {
        type Change = Box<dyn Fn(&mut ZoneSpec)>;
        let cases: Vec<(Change, &str)> = vec![
            (Box::new(|s| s.radius[1] = -0.1), "must be > 0"),
            (Box::new(|s| s.radius[1] = f64::NAN), "finite"),
            (Box::new(|s| s.radius = vec![0.1, 0.09, 0.15]), "must increase outwards"),
            (Box::new(|s| s.grain_d = vec![9e-3, 6e-3, 12e-3]), "must not shrink outwards"),
            (Box::new(|s| s.grain_d.pop().map(|_| ()).unwrap_or(())), "one grain diameter per zone"),
            (Box::new(|s| s.mix = vec![0.0, 0.05]), "narrow the mixing layers"),
            (Box::new(|s| s.mix = vec![0.0, 0.005]), "narrower than one coarse grain"),
            (Box::new(|s| s.mix = vec![0.01]), "one mixing-layer width per interface"),
            (Box::new(|s| s.mix_porosity = 0.9), "[0.2, 0.7)"),
            (Box::new(|s| s.height = 0.01), "taller"),
            (Box::new(|s| s.radius.clear()), "at least one zone"),
        ];
        for (change, expect) in cases {
            let mut s = spec();
            change(&mut s);
            let e = s.validate().unwrap_err().to_string();
            assert!(e.contains(expect), "expected `{expect}` in: {e}");
        }
    }

    #[test]
    fn a_large_chamber_takes_its_ids_in_z_order_with_each_grain_at_its_place() {
        // Grains on a 24 × 24 × 24 grid in a random order, each one's radius and region
        // telling where it was placed: after the reordering every grain still stands at its
        // own place, and grid neighbours are near in id.
        let n = 24usize;
        let mut cells: Vec<usize> = (0..n * n * n).collect();
        let mut rng = Rng::new(9);
        for i in (1..cells.len()).rev() {
            cells.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
        }
        let at = |c: usize| Vec3::new((c % n) as f64, (c / n % n) as f64, (c / (n * n)) as f64) * 1e-3;
        let grains: Vec<(usize, usize, f64)> = cells.iter().map(|&c| (c % 3, c % 2, 5e-4 + c as f64 * 1e-9)).collect();
        let placed: Vec<Vec3> = cells.iter().map(|&c| at(c)).collect();
        assert!(grains.len() > crate::space_filling::SPACE_ORDER_FROM);
        let (g, p) = in_id_order(grains, placed, 1.0);
        let mut id_of = vec![0usize; n * n * n];
        for (id, (grain, x)) in g.iter().zip(&p).enumerate() {
            let c = ((grain.2 - 5e-4) / 1e-9).round() as usize;
            assert_eq!((grain.0, grain.1), (c % 3, c % 2), "grain {id}");
            assert!((x - at(c)).norm() < 1e-12, "grain {id} moved");
            id_of[c] = id;
        }
        let gaps: Vec<usize> =
            (0..n * n * n - 1).filter(|c| c % n != n - 1).map(|c| id_of[c].abs_diff(id_of[c + 1])).collect();
        let mean = gaps.iter().sum::<usize>() as f64 / gaps.len() as f64;
        // Shuffled they lay ~n³/3 apart.
        assert!(mean < (n * n * n) as f64 / 20.0, "x neighbours {mean:.0} ids apart on average");
        // A small chamber keeps the placement order.
        let small: Vec<(usize, usize, f64)> = (0..50).map(|k| (0, 0, 1.0 - k as f64 * 1e-3)).collect();
        let (g, _) = in_id_order(small.clone(), vec![Vec3::zeros(); 50], 1.0);
        assert_eq!(g, small);
    }
}
