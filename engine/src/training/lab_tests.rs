//! Numerical material tests on a bonded sample, strain-controlled: uniaxial compression
//! (E, ν, Cu), uniaxial tension (Tu) and confined compression (a peak σ1 at a confining
//! σ3, for the Mohr–Coulomb envelope).
//!
//! Compression loads the sample between two frictionless platens that approach at a
//! constant speed; confinement adds four servo walls held at σ3. Tension clamps the top and
//! bottom layers of grains and pulls them apart. Strains for E and ν come from a linear fit
//! of the grains' displacements against their positions, so the soft first contact with a
//! platen does not count as material compliance.

use super::fit::line_fit;
use crate::backend::RunControl;
use crate::error::{check_positive, Result};
use crate::model::Model;
use crate::physics::Vec3;
use crate::simulation::{Balance, Simulation};
use crate::state::particles::dof;
use crate::walls::{Wall, WallMotion, WallShape};
use serde::{Deserialize, Serialize};

/// Which test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum LabTest {
    UniaxialCompression,
    UniaxialTension,
    /// Triaxial-style compression with the four sides servo-held at `confining` (Pa).
    ConfinedCompression {
        confining: f64,
    },
}

impl LabTest {
    pub fn name(&self) -> String {
        match self {
            LabTest::UniaxialCompression => "uniaxial_compression".into(),
            LabTest::UniaxialTension => "uniaxial_tension".into(),
            LabTest::ConfinedCompression { confining } => format!("confined_compression_{confining:.4e}"),
        }
    }
}

/// How fast and how far to load.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Loading {
    /// Axial strain per time step. Quasi-static when halving it changes the result little.
    pub strain_per_step: f64,
    /// Strain at which the peak is expected (sets how often the curve is sampled).
    pub expected_peak_strain: f64,
    /// Give up (and take the largest stress as the peak) at this multiple of the expected
    /// peak strain.
    pub max_strain_factor: f64,
    /// The test ends once the stress falls under this fraction of its peak.
    pub stop_ratio: f64,
}

impl Loading {
    /// A rate that reaches `expected_peak_strain` in `steps_to_peak` steps.
    pub fn reaching_peak_in(steps_to_peak: f64, expected_peak_strain: f64) -> Self {
        Loading {
            strain_per_step: expected_peak_strain / steps_to_peak,
            expected_peak_strain,
            max_strain_factor: 4.0,
            stop_ratio: 0.8,
        }
    }

    fn validate(&self) -> Result<()> {
        check_positive("strain_per_step", self.strain_per_step, false)?;
        check_positive("expected_peak_strain", self.expected_peak_strain, false)?;
        check_positive("max_strain_factor", self.max_strain_factor, false)?;
        check_positive("stop_ratio", self.stop_ratio, false)?;
        Ok(())
    }
}

/// One sample of a test's curve. Compression is positive in compression tests, tension in
/// the tension test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Axial strain from the platens (or clamped layers), as a laboratory reports it.
    pub strain: f64,
    /// Axial stress (Pa); for confined compression σ1.
    pub stress: f64,
    /// Axial strain from the grains' displacement field (same sign convention as `strain`).
    pub grain_strain: f64,
    /// Mean lateral strain from the grains' displacement field (extension positive).
    pub lateral_strain: f64,
    pub broken_bonds: usize,
}

/// What a test measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestResult {
    pub test: LabTest,
    pub curve: Vec<CurvePoint>,
    /// Peak axial stress (Pa): Cu, Tu or σ1 at failure.
    pub peak_stress: f64,
    pub peak_strain: f64,
    /// Tangent modulus between 10% and 50% of the peak (Pa).
    pub young: f64,
    /// −(lateral strain)/(axial strain) over the same range.
    pub poisson: f64,
    /// Whether the stress fell after the peak (false: it was still rising at the strain limit).
    pub peaked: bool,
    pub steps: u64,
}

/// Runs `test` on a copy of `sample` (a bonded, balanced model without walls).
pub fn run_test(sample: &Model, test: LabTest, loading: &Loading, ctl: &RunControl) -> Result<TestResult> {
    loading.validate()?;
    if let LabTest::ConfinedCompression { confining } = test {
        check_positive("confining", confining, false)?;
    }
    let mut m = sample.clone();
    let (lo, hi) = extent(&m);
    let size = hi - lo;
    // A 2D sample is a plate: its depth in y is its thickness, and it has no walls in y.
    let planar = m.planar().map(|p| p.thickness);
    let depth = planar.unwrap_or(size.y);
    let area = size.x * depth;
    let dt = m.clock.dt;
    let r_mean = m.mean_radius();
    let mut steps = 0;
    // Each end moves at half the relative speed: symmetric loading halves inertia effects.
    let end_speed = 0.5 * loading.strain_per_step * size.z / dt;
    let tension = test == LabTest::UniaxialTension;
    let (top_layer, bottom_layer) = if tension {
        let top: Vec<u32> =
            (0..m.len() as u32).filter(|&i| m.particles.pos[i as usize].z > hi.z - 2.5 * r_mean).collect();
        let bottom: Vec<u32> =
            (0..m.len() as u32).filter(|&i| m.particles.pos[i as usize].z < lo.z + 2.5 * r_mean).collect();
        m.fix(&top, dof::ALL, true)?;
        m.fix(&bottom, dof::ALL, true)?;
        (top, bottom)
    } else {
        add_plane(&mut m, "bottom", Vec3::new(0.0, 0.0, lo.z), Vec3::z(), area)?;
        add_plane(&mut m, "top", Vec3::new(0.0, 0.0, hi.z), -Vec3::z(), area)?;
        if let LabTest::ConfinedCompression { .. } = test {
            add_plane(&mut m, "left", Vec3::new(lo.x, 0.0, 0.0), Vec3::x(), depth * size.z)?;
            add_plane(&mut m, "right", Vec3::new(hi.x, 0.0, 0.0), -Vec3::x(), depth * size.z)?;
            if planar.is_none() {
                add_plane(&mut m, "front", Vec3::new(0.0, lo.y, 0.0), Vec3::y(), size.x * size.z)?;
                add_plane(&mut m, "back", Vec3::new(0.0, hi.y, 0.0), -Vec3::y(), size.x * size.z)?;
            }
        }
        (Vec::new(), Vec::new())
    };
    let mut sim = Simulation::new(m);
    if let LabTest::ConfinedCompression { confining } = test {
        steps += confine(&mut sim, confining, r_mean, ctl)?;
    }
    let m = &mut sim.model;
    let free: Vec<usize> = (0..m.len()).filter(|&i| m.is_free(i)).collect();
    let origin: Vec<Vec3> = m.particles.pos.clone();
    let length = |m: &Model| -> f64 {
        if tension {
            mean_z(m, &top_layer) - mean_z(m, &bottom_layer)
        } else {
            plane_z(m, "top") - plane_z(m, "bottom")
        }
    };
    let h0 = length(m);
    let broken0 = m.breakages.len();
    // The ends start from rest and reach full speed over the first tenth of the way to the
    // expected peak: a sudden start would send a stress wave through the sample.
    let ramp_steps = (0.1 * loading.expected_peak_strain / loading.strain_per_step).max(1.0);
    // About 150 samples up to the expected peak.
    let every = ((loading.expected_peak_strain / loading.strain_per_step / 150.0).ceil() as u64).max(1);
    let max_strain = loading.max_strain_factor * loading.expected_peak_strain;
    let mut curve = Vec::new();
    let (mut peak, mut peak_at) = (f64::NEG_INFINITY, 0usize);
    let mut peaked = false;
    let mut loaded_steps = 0u64;
    loop {
        let speed = end_speed * (loaded_steps as f64 / ramp_steps).min(1.0);
        set_end_speed(&mut sim.model, tension, speed, &top_layer, &bottom_layer)?;
        sim.run(every, ctl, &mut |_| {})?;
        steps += every;
        loaded_steps += every;
        let m = &mut sim.model;
        let h = length(m);
        let strain = if tension { (h - h0) / h0 } else { (h0 - h) / h0 };
        if let LabTest::ConfinedCompression { .. } = test {
            // The side walls shrink in height with the sample: keep their stress honest.
            side_areas(m, h);
        }
        let stress = if tension {
            let pull = |ids: &[u32]| ids.iter().map(|&i| m.particles.force[i as usize].z).sum::<f64>();
            0.5 * (pull(&bottom_layer) - pull(&top_layer)) / area
        } else {
            0.5 * (m.walls[m.wall_index("top")?].stress() + m.walls[m.wall_index("bottom")?].stress())
        };
        let ez = grain_strain(m, &free, &origin, 2);
        // A 2D sample's lateral strain is in x alone.
        let lateral = match planar {
            Some(_) => grain_strain(m, &free, &origin, 0),
            None => 0.5 * (grain_strain(m, &free, &origin, 0) + grain_strain(m, &free, &origin, 1)),
        };
        let grain = if tension { ez } else { -ez };
        curve.push(CurvePoint {
            strain,
            stress,
            grain_strain: grain,
            lateral_strain: lateral,
            broken_bonds: m.breakages.len() - broken0,
        });
        if stress > peak {
            peak = stress;
            peak_at = curve.len() - 1;
        }
        // A drop counts only past a fifth of the expected peak strain: the first contacts
        // of a platen rattle.
        if peak > 0.0 && stress < loading.stop_ratio * peak && strain > 0.2 * loading.expected_peak_strain {
            peaked = true;
            break;
        }
        if strain > max_strain {
            break;
        }
    }
    let (young, poisson) = elastic_constants(&curve[..=peak_at], peak, !tension);
    Ok(TestResult { test, peak_strain: curve[peak_at].strain, curve, peak_stress: peak, young, poisson, peaked, steps })
}

/// Tangent E and ν between 10% and 50% of the peak, before it (falls back to every
/// pre-peak point under 70% when that range has fewer than three samples).
fn elastic_constants(pre_peak: &[CurvePoint], peak: f64, compression: bool) -> (f64, f64) {
    let pick = |lo: f64, hi: f64| -> Vec<&CurvePoint> {
        pre_peak.iter().filter(|c| c.stress >= lo * peak && c.stress <= hi * peak).collect()
    };
    let mut pts = pick(0.1, 0.5);
    if pts.len() < 3 {
        pts = pick(0.0, 0.7);
    }
    let ax: Vec<f64> = pts.iter().map(|c| c.grain_strain).collect();
    let s: Vec<f64> = pts.iter().map(|c| c.stress).collect();
    let lat: Vec<f64> = pts.iter().map(|c| c.lateral_strain).collect();
    let young = line_fit(&ax, &s).map_or(f64::NAN, |(_, b)| b);
    // Lateral strain is extension-positive; axial strain is compression-positive in
    // compression tests (so ν is the slope) and extension-positive in tension (ν = −slope).
    let sign = if compression { 1.0 } else { -1.0 };
    let poisson = line_fit(&ax, &lat).map_or(f64::NAN, |(_, b)| sign * b);
    (young, poisson)
}

/// Brings all six walls to `stress` by servo control and balances (hydrostatic start).
fn confine(sim: &mut Simulation, stress: f64, r_mean: f64, ctl: &RunControl) -> Result<u64> {
    let max_speed = 2e-3 * r_mean / sim.model.clock.dt;
    for w in &mut sim.model.walls {
        w.motion = WallMotion::Servo { stress, max_speed };
    }
    let mut steps = 0;
    while steps < 200_000 {
        let rep = sim.balance(Balance::Tolerance { ratio: 0.01, max_steps: 1000 }, ctl, &mut |_| {})?;
        steps += rep.steps;
        let m = &mut sim.model;
        let h = plane_z(m, "top") - plane_z(m, "bottom");
        side_areas(m, h);
        let all_there = m.walls.iter().all(|w| (w.stress() - stress).abs() < 0.02 * stress);
        if all_there && rep.unbalanced_ratio.unwrap_or(1.0) < 0.01 {
            break;
        }
    }
    for w in &mut sim.model.walls {
        if w.name == "top" || w.name == "bottom" {
            w.motion = WallMotion::Fixed;
        }
    }
    Ok(steps)
}

/// Sets the side walls' areas for the sample's height `h`: width × h across x and y in 3D,
/// thickness × h on the two sides of a 2D sample.
fn side_areas(m: &mut Model, h: f64) {
    let (w, l) = match m.planar() {
        Some(p) => (0.0, p.thickness),
        None => (plane_x(m, "right") - plane_x(m, "left"), plane_y(m, "back") - plane_y(m, "front")),
    };
    for (name, a) in [("left", l * h), ("right", l * h), ("front", w * h), ("back", w * h)] {
        if let Ok(k) = m.wall_index(name) {
            m.walls[k].area = a;
        }
    }
}

/// Moves the loaded ends apart (tension) or together (compression) at `speed` each.
fn set_end_speed(m: &mut Model, tension: bool, speed: f64, top: &[u32], bottom: &[u32]) -> Result<()> {
    if tension {
        for &i in top {
            m.particles.vel[i as usize] = Vec3::new(0.0, 0.0, speed);
        }
        for &i in bottom {
            m.particles.vel[i as usize] = Vec3::new(0.0, 0.0, -speed);
        }
    } else {
        let (t, b) = (m.wall_index("top")?, m.wall_index("bottom")?);
        m.walls[t].motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, -speed));
        m.walls[b].motion = WallMotion::Velocity(Vec3::new(0.0, 0.0, speed));
    }
    Ok(())
}

fn add_plane(m: &mut Model, name: &str, point: Vec3, normal: Vec3, area: f64) -> Result<()> {
    let mut w = Wall::plane(name, point, normal, area)?;
    w.friction = Some(0.0); // smooth platens: no end restraint
    m.add_wall(w)?;
    Ok(())
}

/// Bounding box of the spheres.
fn extent(m: &Model) -> (Vec3, Vec3) {
    let p = &m.particles;
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for (x, r) in p.pos.iter().zip(&p.radius) {
        lo = lo.inf(&(x - Vec3::repeat(*r)));
        hi = hi.sup(&(x + Vec3::repeat(*r)));
    }
    (lo, hi)
}

fn plane_point(m: &Model, name: &str) -> Vec3 {
    match m.wall_index(name).map(|k| &m.walls[k].shape) {
        Ok(WallShape::Plane { point, .. }) => *point,
        _ => Vec3::zeros(),
    }
}

fn plane_x(m: &Model, name: &str) -> f64 {
    plane_point(m, name).x
}

fn plane_y(m: &Model, name: &str) -> f64 {
    plane_point(m, name).y
}

fn plane_z(m: &Model, name: &str) -> f64 {
    plane_point(m, name).z
}

fn mean_z(m: &Model, ids: &[u32]) -> f64 {
    ids.iter().map(|&i| m.particles.pos[i as usize].z).sum::<f64>() / ids.len().max(1) as f64
}

/// Normal strain along axis `k` (extension positive): the slope of the grains'
/// displacement against their starting position.
fn grain_strain(m: &Model, ids: &[usize], origin: &[Vec3], k: usize) -> f64 {
    let x: Vec<f64> = ids.iter().map(|&i| origin[i][k]).collect();
    let u: Vec<f64> = ids.iter().map(|&i| m.particles.pos[i][k] - origin[i][k]).collect();
    line_fit(&x, &u).map_or(f64::NAN, |(_, b)| b)
}
