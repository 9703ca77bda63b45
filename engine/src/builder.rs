//! Building particle assemblies: regular lattices (for tests and benchmarks) and MatDEM's
//! box builder (`obj_Box`): a loose arrangement of a gradation inside a container, ready for
//! deposition and compaction.

use crate::backend::RunControl;
use crate::error::{check_positive, Error, Result};
use crate::model::Model;
use crate::physics::Vec3;
use crate::walls::Wall;
use serde::{Deserialize, Serialize};

/// A small deterministic generator (SplitMix64): the same seed gives the same model on every
/// machine, which a shared script relies on.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Centres of a face-centred cubic block of spheres of diameter `d`, stacked as close-packed
/// layers (ABC) along z, so z is the lattice's [111] direction. `nx` × `ny` per layer.
pub fn fcc_111_block(nx: usize, ny: usize, layers: usize, d: f64) -> Vec<Vec3> {
    let row = d * 3f64.sqrt() / 2.0;
    let layer_h = d * (2.0f64 / 3.0).sqrt();
    let mut out = Vec::with_capacity(nx * ny * layers);
    for k in 0..layers {
        // B and C layers sit over the triangle centres of the layer below.
        let (sx, sy) = match k % 3 {
            0 => (0.0, 0.0),
            1 => (d / 2.0, row / 3.0),
            _ => (d, 2.0 * row / 3.0),
        };
        for j in 0..ny {
            for i in 0..nx {
                let x = i as f64 * d + if j % 2 == 1 { d / 2.0 } else { 0.0 } + sx;
                out.push(Vec3::new(x, j as f64 * row + sy, k as f64 * layer_h));
            }
        }
    }
    out
}

/// Centres of a simple cubic lattice with spacing `s`, first centre at `origin`.
pub fn simple_cubic(nx: usize, ny: usize, nz: usize, s: f64, origin: Vec3) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                out.push(origin + Vec3::new(i as f64, j as f64, k as f64) * s);
            }
        }
    }
    out
}

/// One size class of a gradation: radii uniform in [r_min, r_max], a share of the mass.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SizeClass {
    pub r_min: f64,
    pub r_max: f64,
    pub mass_ratio: f64,
}

/// The container of a box model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Container {
    /// width (x) × length (y), sides as planes.
    Cuboid { width: f64, length: f64 },
    /// A vertical cylinder of this radius (the oedometer ring), centred on the origin.
    Cylinder { radius: f64 },
    /// A 2D box of this width (x) in the x–z plane (MatDEM's `sampleL = 0`): one layer of
    /// elements at y = 0, the model made 2D ([`crate::planar`]).
    Rectangle { width: f64 },
}

/// MatDEM's box: a sample of `height` in a container, filled loosely with the gradation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoxSpec {
    pub container: Container,
    pub height: f64,
    pub classes: Vec<SizeClass>,
    /// Porosity the settled sample is expected to reach (sets the particle count).
    pub target_porosity: f64,
    pub seed: u64,
    /// Add a top platen (a plane that can be moved or servo-controlled).
    pub top_platen: bool,
}

/// The particles of a built box: ids per size class, and the loose height reached.
#[derive(Debug, Clone, PartialEq)]
pub struct BuiltBox {
    pub class_ids: Vec<Vec<u32>>,
    pub loose_height: f64,
}

/// The most particles a box builds: well above the paper's largest samples (4·10⁵), well
/// under what would exhaust memory (each particle costs about 1 kB with its contact rows).
pub const MAX_BOX_PARTICLES: usize = 20_000_000;

impl BoxSpec {
    pub fn validate(&self) -> Result<()> {
        check_positive("height", self.height, false)?;
        match self.container {
            Container::Cuboid { width, length } => {
                check_positive("width", width, false)?;
                check_positive("length", length, false)?;
            }
            Container::Cylinder { radius } => {
                check_positive("radius", radius, false)?;
            }
            Container::Rectangle { width } => {
                check_positive("width", width, false)?;
            }
        }
        if self.classes.is_empty() {
            return Err(Error::InvalidScene("a box needs at least one size class".into()));
        }
        for c in &self.classes {
            check_positive("r_min", c.r_min, false)?;
            check_positive("r_max", c.r_max, false)?;
            check_positive("mass_ratio", c.mass_ratio, false)?;
            if c.r_max < c.r_min {
                return Err(Error::InvalidScene(format!(
                    "size class with r_min {} > r_max {}: give the smaller radius first",
                    c.r_min, c.r_max
                )));
            }
        }
        // A grain wider than the container cannot be placed in it (a radius given in mm,
        // say, would build one grain through the walls).
        let span = match self.container {
            Container::Cuboid { width, length } => width.min(length),
            Container::Cylinder { radius } => 2.0 * radius,
            Container::Rectangle { width } => width,
        };
        let r_max = self.classes.iter().map(|c| c.r_max).fold(0.0, f64::max);
        if 2.0 * r_max > span {
            return Err(Error::InvalidScene(format!(
                "the largest grains, of radius {r_max} m, are {} m across, wider than the box ({span} m): use \
                 smaller grains (ball_r, gradation; lengths are in metres) or a wider box",
                2.0 * r_max
            )));
        }
        if !(0.0..0.9).contains(&self.target_porosity) {
            return Err(Error::param("target_porosity", self.target_porosity, "must be in [0, 0.9)"));
        }
        // Summed in f64: a tiny radius in a large box would overflow a count of particles.
        let total: f64 = self.counts().iter().map(|&n| n as f64).sum();
        if total > MAX_BOX_PARTICLES as f64 {
            return Err(Error::InvalidScene(format!(
                "the box would hold about {total:.3e} particles, more than the {MAX_BOX_PARTICLES} a box may build: \
                 use larger grains (ball_r, gradation) or a smaller box"
            )));
        }
        Ok(())
    }

    /// The container's cross-section: an area in 3D, the width of a 2D box (whose "volumes"
    /// are areas of the x–z plane).
    fn cross_section(&self) -> f64 {
        match self.container {
            Container::Cuboid { width, length } => width * length,
            Container::Cylinder { radius } => std::f64::consts::PI * radius * radius,
            Container::Rectangle { width } => width,
        }
    }

    fn planar(&self) -> bool {
        matches!(self.container, Container::Rectangle { .. })
    }

    /// An element's solid: its sphere's volume in 3D, its disc's area in 2D.
    fn solid_of(&self, r: f64) -> f64 {
        if self.planar() {
            std::f64::consts::PI * r * r
        } else {
            4.0 / 3.0 * std::f64::consts::PI * r.powi(3)
        }
    }

    /// Particles per class so the settled sample fills `height` at `target_porosity` (by area
    /// in a 2D box).
    pub fn counts(&self) -> Vec<usize> {
        let solid = self.cross_section() * self.height * (1.0 - self.target_porosity);
        let total_ratio: f64 = self.classes.iter().map(|c| c.mass_ratio).sum();
        self.classes
            .iter()
            .map(|c| {
                // Mean area of a disc with r uniform in [a, b]: π·(b³ − a³)/(3(b − a)).
                let v = if self.planar() {
                    if c.r_max > c.r_min {
                        std::f64::consts::PI / 3.0 * (c.r_max.powi(3) - c.r_min.powi(3)) / (c.r_max - c.r_min)
                    } else {
                        self.solid_of(c.r_min)
                    }
                // Mean volume of a sphere with r uniform in [a, b]: (4π/3)·(b⁴ − a⁴)/(4(b − a)).
                } else if c.r_max > c.r_min {
                    std::f64::consts::PI / 3.0 * (c.r_max.powi(4) - c.r_min.powi(4)) / (c.r_max - c.r_min)
                } else {
                    4.0 / 3.0 * std::f64::consts::PI * c.r_min.powi(3)
                };
                (solid * c.mass_ratio / total_ratio / v).round().max(1.0) as usize
            })
            .collect()
    }

    /// Adds the particles (material 0 must exist) and the walls to `m`: `bottom`, the sides
    /// (`left`, `right`, `front`, `back`, or `ring`) and, if asked, `top_platen`.
    pub fn build_into(&self, m: &mut Model) -> Result<BuiltBox> {
        self.build_into_until(m, &RunControl::default())
    }

    /// [`BoxSpec::build_into`] that stops with [`Error::Cancelled`] soon after `control` is
    /// cancelled (a large box packs for minutes).
    pub fn build_into_until(&self, m: &mut Model, control: &RunControl) -> Result<BuiltBox> {
        self.validate()?;
        if m.materials.is_empty() {
            return Err(Error::InvalidScene("add a material before building a box".into()));
        }
        let counts = self.counts();
        let total: usize = counts.iter().sum();
        crate::memory_budget::check_fits("the box", total as u64, crate::memory_budget::CPU_BYTES_PER_PARTICLE)?;
        let r_max = self.classes.iter().map(|c| c.r_max).fold(0.0, f64::max);
        let mut rng = Rng::new(self.seed);
        let mut grains: Vec<(usize, f64)> = Vec::with_capacity(total);
        for (k, (&n, c)) in counts.iter().zip(&self.classes).enumerate() {
            for _ in 0..n {
                grains.push((k, c.r_min + (c.r_max - c.r_min) * rng.uniform()));
            }
        }
        // Largest first: random sequential addition packs a wide gradation far better so.
        grains.sort_by(|a, b| b.1.total_cmp(&a.1));
        let solid: f64 = grains.iter().map(|g| self.solid_of(g.1)).sum();
        // A loose column at ~33% solids: grains fall less than a grid would make them.
        let loose_height = (solid / (LOOSE_SOLID_FRACTION * self.cross_section())).max(2.0 * r_max);
        let placed = self.random_sequential_addition(&grains, loose_height, &mut rng, control)?;
        let mut class_ids = vec![Vec::new(); self.classes.len()];
        let mean_d = 2.0 * grains.iter().map(|g| g.1).sum::<f64>() / grains.len().max(1) as f64;
        for k in crate::space_filling::id_order(&placed, mean_d) {
            let (class, r) = grains[k];
            let id = m.add_particle(placed[k], r, 0)?;
            class_ids[class].push(id as u32);
        }
        let loose_height = placed.iter().zip(&grains).map(|(p, g)| p.z + g.1).fold(0.0, f64::max);
        let top = loose_height.max(self.height);
        let z = Vec3::z();
        // A 2D box's walls are lines of the plate: their areas are lengths × its thickness.
        let depth = if let Container::Rectangle { .. } = self.container {
            if m.planar().is_none() {
                m.make_planar(None)?;
            }
            m.planar().map_or(1.0, |p| p.thickness)
        } else {
            1.0
        };
        m.add_wall(Wall::plane("bottom", Vec3::zeros(), z, self.cross_section() * depth)?)?;
        match self.container {
            Container::Rectangle { width } => {
                m.add_wall(Wall::plane("left", Vec3::zeros(), Vec3::x(), depth * top)?)?;
                m.add_wall(Wall::plane("right", Vec3::new(width, 0.0, 0.0), -Vec3::x(), depth * top)?)?;
            }
            Container::Cuboid { width, length } => {
                m.add_wall(Wall::plane("left", Vec3::zeros(), Vec3::x(), length * top)?)?;
                m.add_wall(Wall::plane("right", Vec3::new(width, 0.0, 0.0), -Vec3::x(), length * top)?)?;
                m.add_wall(Wall::plane("front", Vec3::zeros(), Vec3::y(), width * top)?)?;
                m.add_wall(Wall::plane("back", Vec3::new(0.0, length, 0.0), -Vec3::y(), width * top)?)?;
            }
            Container::Cylinder { radius } => {
                let area = 2.0 * std::f64::consts::PI * radius * self.height;
                m.add_wall(Wall::cylinder("ring", Vec3::zeros(), radius, area)?)?;
            }
        }
        if self.top_platen {
            m.add_wall(Wall::plane("top_platen", Vec3::new(0.0, 0.0, top), -z, self.cross_section() * depth)?)?;
        }
        Ok(BuiltBox { class_ids, loose_height })
    }

    /// Places grains one by one at random non-overlapping positions inside the container,
    /// in a column of height `height` that grows when it runs out of room.
    fn random_sequential_addition(
        &self,
        grains: &[(usize, f64)],
        height: f64,
        rng: &mut Rng,
        control: &RunControl,
    ) -> Result<Vec<Vec3>> {
        let r_max = grains.iter().map(|g| g.1).fold(0.0, f64::max);
        let (lo, hi) = match self.container {
            Container::Cuboid { width, length } => (Vec3::zeros(), Vec3::new(width, length, 0.0)),
            Container::Cylinder { radius } => (Vec3::new(-radius, -radius, 0.0), Vec3::new(radius, radius, 0.0)),
            Container::Rectangle { width } => (Vec3::zeros(), Vec3::new(width, 0.0, 0.0)),
        };
        let h = 2.0 * r_max;
        let (nx, ny) = (((hi.x - lo.x) / h) as usize + 1, ((hi.y - lo.y) / h) as usize + 1);
        let mut height = height;
        let mut cells: std::collections::HashMap<(usize, usize, usize), Vec<u32>> = Default::default();
        let mut placed: Vec<Vec3> = Vec::with_capacity(grains.len());
        for (k, &(_, r)) in grains.iter().enumerate() {
            // After every 1024 grains placed: a small box always builds.
            if k % 1024 == 1023 && control.is_cancelled() {
                return Err(Error::Cancelled { completed_steps: 0 });
            }
            let mut tries = 0;
            let pos = loop {
                tries += 1;
                if tries % 200 == 0 {
                    height *= 1.05; // crowded: let the column grow a little
                }
                if tries > 100_000 {
                    return Err(Error::InvalidScene(format!(
                        "could not place grain {k} (radius {r}) in the container: it is too small for the gradation"
                    )));
                }
                let x = lo.x + r + (hi.x - lo.x - 2.0 * r) * rng.uniform();
                let y = if self.planar() { 0.0 } else { lo.y + r + (hi.y - lo.y - 2.0 * r) * rng.uniform() };
                let z = r + (height - 2.0 * r).max(0.0) * rng.uniform();
                if let Container::Cylinder { radius } = self.container {
                    if (x * x + y * y).sqrt() + r > radius {
                        continue;
                    }
                }
                let c = Vec3::new(x, y, z);
                let cell = |v: &Vec3| (((v.x - lo.x) / h) as usize, ((v.y - lo.y) / h) as usize, (v.z / h) as usize);
                let (cx, cy, cz) = cell(&c);
                let mut free = true;
                'search: for iz in cz.saturating_sub(1)..=cz + 1 {
                    for iy in cy.saturating_sub(1)..=(cy + 1).min(ny) {
                        for ix in cx.saturating_sub(1)..=(cx + 1).min(nx) {
                            for &j in cells.get(&(ix, iy, iz)).map(|v| v.as_slice()).unwrap_or(&[]) {
                                let rj = grains[j as usize].1;
                                if (placed[j as usize] - c).norm() < r + rj {
                                    free = false;
                                    break 'search;
                                }
                            }
                        }
                    }
                }
                if free {
                    cells.entry(cell(&c)).or_default().push(k as u32);
                    break c;
                }
            };
            placed.push(pos);
        }
        Ok(placed)
    }
}

/// Solid fraction of the loose column the box builder fills before deposition.
const LOOSE_SOLID_FRACTION: f64 = 0.3;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::Material;
    use crate::space_filling::SPACE_ORDER_FROM;

    #[test]
    fn box_ids_follow_space_and_keep_their_classes() {
        let mut m = Model::new();
        m.add_material(Material::from_micro("sand", 2650.0, 2e5, 1e5, 0.0, 0.0, 0.5, 0.25e-3).unwrap()).unwrap();
        let classes = vec![
            SizeClass { r_min: 0.3e-3, r_max: 0.4e-3, mass_ratio: 1.0 },
            SizeClass { r_min: 0.15e-3, r_max: 0.2e-3, mass_ratio: 1.0 },
        ];
        let spec = BoxSpec {
            container: Container::Cuboid { width: 16e-3, length: 16e-3 },
            height: 12e-3,
            classes: classes.clone(),
            target_porosity: 0.4,
            seed: 3,
            top_platen: false,
        };
        let built = spec.build_into(&mut m).unwrap();
        let n = m.len();
        assert!(n > SPACE_ORDER_FROM, "{n} grains");
        // Every id once, in the class its radius belongs to.
        let mut seen = vec![false; n];
        for (c, ids) in built.class_ids.iter().enumerate() {
            for &i in ids {
                let r = m.particles.radius[i as usize];
                assert!((classes[c].r_min..=classes[c].r_max).contains(&r), "grain {i} of class {c}: r {r}");
                assert!(!std::mem::replace(&mut seen[i as usize], true), "grain {i} listed twice");
            }
        }
        assert!(seen.iter().all(|s| *s));
        // Grains within a large diameter of each other lie under n/20 ids apart on average;
        // in the order they were placed (at random, largest first) they lay ~n/3 apart.
        let (mut gap, mut pairs) = (0usize, 0usize);
        let p = &m.particles.pos;
        for i in 0..n {
            for j in i + 1..n {
                if (p[i] - p[j]).norm() < 0.8e-3 {
                    gap += j - i;
                    pairs += 1;
                }
            }
        }
        let mean = gap as f64 / pairs as f64;
        assert!(pairs > n, "{pairs} near pairs");
        assert!(mean < n as f64 / 20.0, "near grains are {mean:.0} ids apart on average, of {n}");
    }

    // A grain wider than the container is refused before anything is built, with the sizes
    // and the fix; one that just fits is built.
    #[test]
    fn a_grain_wider_than_the_box_is_refused_with_the_sizes() {
        let spec = |container, r: f64| BoxSpec {
            container,
            height: 4e-3,
            classes: vec![SizeClass { r_min: r / 2.0, r_max: r, mass_ratio: 1.0 }],
            target_porosity: 0.4,
            seed: 3,
            top_platen: false,
        };
        for container in [
            Container::Cuboid { width: 4e-3, length: 6e-3 },
            Container::Cylinder { radius: 2e-3 },
            Container::Rectangle { width: 4e-3 },
        ] {
            for r in [2.5e-3, 0.01, 1e300] {
                let e = spec(container, r).validate().unwrap_err().to_string();
                assert!(
                    e.contains(&format!("the largest grains, of radius {r} m,"))
                        && e.contains("wider than the box (0.004 m)"),
                    "{e}"
                );
                assert!(e.contains("use smaller grains"), "{e}");
            }
            spec(container, 2e-3).validate().unwrap();
            let mut m = Model::new();
            m.add_material(Material::from_micro("sand", 2650.0, 2e5, 1e5, 0.0, 0.0, 0.5, 1e-3).unwrap()).unwrap();
            assert!(spec(container, 2e-3).build_into(&mut m).is_ok(), "{container:?}");
        }
    }

    #[test]
    fn a_small_box_numbers_its_grains_as_it_placed_them_largest_first() {
        let mut m = Model::new();
        m.add_material(Material::from_micro("sand", 2650.0, 2e5, 1e5, 0.0, 0.0, 0.5, 0.25e-3).unwrap()).unwrap();
        let spec = BoxSpec {
            container: Container::Cuboid { width: 4e-3, length: 4e-3 },
            height: 4e-3,
            classes: vec![SizeClass { r_min: 0.15e-3, r_max: 0.4e-3, mass_ratio: 1.0 }],
            target_porosity: 0.4,
            seed: 3,
            top_platen: false,
        };
        spec.build_into(&mut m).unwrap();
        assert!(m.len() > 100 && m.len() <= SPACE_ORDER_FROM);
        assert!(m.particles.radius.windows(2).all(|w| w[0] >= w[1]), "not largest first");
    }
}
