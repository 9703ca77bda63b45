//! The sample the material tests load: a box of spheres packed once (frictionless grains
//! grown in place until they jam, then held by a servo platen at a small stress), then
//! bonded where the grains touch, as MatDEM packs, connects and cuts its training sample.
//! Packing depends only on geometry, so one packing serves every round of training; each
//! round bonds it with its own material.

use super::dimension::Dimension;
use crate::backend::RunControl;
use crate::builder::{BoxSpec, Container, SizeClass};
use crate::error::{check_positive, Error, Result};
use crate::materials::Material;
use crate::model::Model;
use crate::physics::Vec3;
use crate::simulation::{Balance, Simulation};
use crate::walls::{WallMotion, WallShape};
use serde::{Deserialize, Serialize};

/// Size and grains of a training sample: a square prism `aspect` times taller than wide.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SampleSpec {
    /// About this many elements.
    pub elements: usize,
    /// Mean element radius (m).
    pub radius: f64,
    /// Radii spread uniformly over radius·(1 ± distri_rate) (MatDEM's `distriRate`).
    pub distri_rate: f64,
    /// Height over width (2 for a standard uniaxial specimen).
    pub aspect: f64,
    pub seed: u64,
    /// A 3D box, or a 2D one (one layer in the x–z plane, a 2D model). Files written before
    /// 2D samples read as 3D.
    #[serde(default)]
    pub dimension: Dimension,
}

impl Default for SampleSpec {
    fn default() -> Self {
        SampleSpec { elements: 1000, radius: 1e-3, distri_rate: 0.2, aspect: 2.0, seed: 1, dimension: Dimension::Three }
    }
}

impl SampleSpec {
    pub fn validate(&self) -> Result<()> {
        check_positive("radius", self.radius, false)?;
        check_positive("aspect", self.aspect, false)?;
        if !(50..=200_000).contains(&self.elements) {
            return Err(Error::param(
                "elements",
                self.elements as f64,
                "a training sample needs 50 to 200000 elements (a few hundred to ~2000 is usual)",
            ));
        }
        if !(0.0..0.9).contains(&self.distri_rate) {
            return Err(Error::param("distri_rate", self.distri_rate, "must be in [0, 0.9)"));
        }
        Ok(())
    }
}

/// Porosity the packing is sized for (a frictionless random packing jams near 0.36–0.40; a
/// 2D one of discs near 0.16–0.18, by area).
const PACK_POROSITY: f64 = 0.38;
const PACK_POROSITY_2D: f64 = 0.17;
/// Platen stress while packing, as a strain of the lattice: σ = PACK_STRAIN·E_lattice.
/// Small, so the bonded sample starts nearly stress-free.
const PACK_STRAIN: f64 = 1e-4;
/// Solid fraction of the random placement the grains grow from.
const START_SOLID_FRACTION: f64 = 0.3;
/// Radius expansion: increments, and steps after each.
const GROWTH_INCREMENTS: u64 = 40;
const GROWTH_STEPS: u64 = 250;
/// Unbalanced force ratio that ends relaxing the bonded sample.
const BALANCE_RATIO: f64 = 0.01;
/// Unbalanced force ratio that ends packing: frictionless grains at a small stress keep
/// creeping, and a looser balance does not change the jammed geometry.
const PACK_BALANCE_RATIO: f64 = 0.05;

/// A packed sample's geometry: centres and radii, ready to be bonded with any material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PackedSample {
    pub pos: Vec<Vec3>,
    pub radius: Vec<f64>,
    /// Steps the packing took.
    pub steps: u64,
    /// A 2D sample's plate thickness (m); `None` for a 3D sample.
    #[serde(default)]
    pub thickness: Option<f64>,
}

impl PackedSample {
    /// Packs `spec` with `material`'s stiffness (no friction, no bonds): grains placed
    /// loosely in a box, a servo platen presses them until they jam at a small stress.
    pub fn pack(spec: &SampleSpec, material: &Material, ctl: &RunControl) -> Result<Self> {
        spec.validate()?;
        let (r0, r1) = (spec.radius * (1.0 - spec.distri_rate), spec.radius * (1.0 + spec.distri_rate));
        let planar = spec.dimension == Dimension::Two;
        // Grains start shrunk by `s` so that random placement fills the final box at a
        // solid fraction it can reach; they then grow back in place (radius expansion):
        // the whole box jams at once instead of a platen sweeping a loose column.
        let (width, s, container) = if planar {
            // Mean disc area for r uniform in [r0, r1]: (π/3)·(r1³ − r0³)/(r1 − r0).
            let a_grain = if r1 > r0 {
                std::f64::consts::PI / 3.0 * (r1.powi(3) - r0.powi(3)) / (r1 - r0)
            } else {
                std::f64::consts::PI * r0 * r0
            };
            let area = spec.elements as f64 * a_grain / (1.0 - PACK_POROSITY_2D);
            let width = (area / spec.aspect).sqrt();
            (width, (START_SOLID_FRACTION / (1.0 - PACK_POROSITY_2D)).sqrt(), Container::Rectangle { width })
        } else {
            // Mean sphere volume for r uniform in [r0, r1]: (π/3)·(r1⁴ − r0⁴)/(r1 − r0).
            let v_grain = if r1 > r0 {
                std::f64::consts::PI / 3.0 * (r1.powi(4) - r0.powi(4)) / (r1 - r0)
            } else {
                4.0 / 3.0 * std::f64::consts::PI * r0.powi(3)
            };
            let volume = spec.elements as f64 * v_grain / (1.0 - PACK_POROSITY);
            let width = (volume / spec.aspect).cbrt();
            let s = (START_SOLID_FRACTION / (1.0 - PACK_POROSITY)).cbrt();
            (width, s, Container::Cuboid { width, length: width })
        };
        let box_spec = BoxSpec {
            container,
            height: spec.aspect * width,
            classes: vec![SizeClass { r_min: s * r0, r_max: s * r1, mass_ratio: 1.0 }],
            target_porosity: 1.0 - START_SOLID_FRACTION,
            seed: spec.seed,
            top_platen: true,
        };
        let mut packing = material.clone();
        packing.name = "packing".into();
        packing.mu_p = 0.0;
        packing.fs0 = 0.0;
        packing.xb = 0.0;
        let d = 2.0 * spec.radius;
        let stress = PACK_STRAIN * spec.dimension.lattice_macro(&packing, d).young;
        let density = packing.density;
        let mut m = Model::new();
        m.add_material(packing)?;
        box_spec.build_into(&mut m)?;
        m.settings.local_damping = 0.7;
        // The shrunk grains are the lightest the packing sees: their step is safe throughout.
        let dt = m.set_standard_dt()?;
        let full: Vec<f64> = m.particles.radius.iter().map(|r| r / s).collect();
        let mut sim = Simulation::new(m);
        let mut steps = 0;
        for k in 1..=GROWTH_INCREMENTS {
            let f = s + (1.0 - s) * k as f64 / GROWTH_INCREMENTS as f64;
            let p = &mut sim.model.particles;
            for i in 0..p.len() {
                p.radius[i] = full[i] * f;
                p.mass[i] = density * 4.0 / 3.0 * std::f64::consts::PI * p.radius[i].powi(3);
            }
            sim.model.contacts.stale = true;
            sim.run(GROWTH_STEPS, ctl, &mut |_| {})?;
            steps += GROWTH_STEPS;
        }
        // The grown grains are near jamming; a servo platen brings them to the small
        // packing stress, so the bonds start nearly unloaded.
        let top = sim.model.wall_index("top_platen")?;
        if planar {
            // The plate was made as thick as the shrunk grains: now as the grown ones, so the
            // platen's stress is its force over width × the grains' diameter.
            let t = 2.0 * sim.model.mean_radius();
            sim.model.make_planar(Some(t))?;
            sim.model.walls[top].area = width * t;
        }
        let z_top =
            sim.model.particles.pos.iter().zip(&sim.model.particles.radius).map(|(x, r)| x.z + r).fold(0.0, f64::max);
        sim.model.walls[top].shape = WallShape::Plane { point: Vec3::new(0.0, 0.0, z_top), normal: -Vec3::z() };
        sim.model.walls[top].motion = WallMotion::Servo { stress, max_speed: 2e-3 * spec.radius / dt };
        sim.model.contacts.stale = true;
        let until = steps + 40_000;
        while steps < until {
            let rep =
                sim.balance(Balance::Tolerance { ratio: PACK_BALANCE_RATIO, max_steps: 500 }, ctl, &mut |_| {})?;
            steps += rep.steps;
            let st = sim.model.walls[top].stress();
            if (st - stress).abs() < 0.05 * stress && rep.unbalanced_ratio.unwrap_or(1.0) < PACK_BALANCE_RATIO {
                break;
            }
        }
        let p = &sim.model.particles;
        let thickness = sim.model.planar().map(|pl| pl.thickness);
        Ok(PackedSample { pos: p.pos.clone(), radius: p.radius.clone(), steps, thickness })
    }

    pub fn len(&self) -> usize {
        self.pos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Mean element diameter (m): the `d` of the conversion formulas.
    pub fn diameter(&self) -> f64 {
        2.0 * self.radius.iter().sum::<f64>() / self.len().max(1) as f64
    }

    /// The same packing, every length multiplied by `s` (for element-size scaling).
    pub fn scaled(&self, s: f64) -> Self {
        PackedSample {
            pos: self.pos.iter().map(|x| x * s).collect(),
            radius: self.radius.iter().map(|r| r * s).collect(),
            steps: self.steps,
            thickness: self.thickness.map(|t| t * s),
        }
    }

    /// The sample bonded with `material` where grains touch, freed from the box and
    /// balanced: what every material test starts from.
    pub fn bonded(&self, material: &Material, ctl: &RunControl) -> Result<Model> {
        let mut m = Model::new();
        let k = m.add_material(material.clone())?;
        for (x, r) in self.pos.iter().zip(&self.radius) {
            m.add_particle(*x, *r, k)?;
        }
        m.groups.set("sample", (0..m.len() as u32).collect());
        if let Some(t) = self.thickness {
            m.make_planar(Some(t))?;
        }
        // Only touching pairs: a bond across a gap would start in tension (the bonded
        // spring counts from touching), and for a rock that tension exceeds Kn·Xb.
        let bonds = m.connect(None, 0.0)?;
        if bonds == 0 {
            return Err(Error::InvalidScene("the packed sample has no touching grains to bond".into()));
        }
        m.settings.local_damping = 0.7;
        m.set_standard_dt()?;
        // Out of the box the packing stress relaxes: the bonded sample swells a little.
        let mut sim = Simulation::new(m);
        sim.balance(Balance::Tolerance { ratio: BALANCE_RATIO, max_steps: 50_000 }, ctl, &mut |_| {})?;
        let mut m = sim.model;
        for v in &mut m.particles.vel {
            *v = Vec3::zeros();
        }
        Ok(m)
    }
}
