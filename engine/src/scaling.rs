//! Scaled copies of a packing and the stiffness scaling law of paper 001 §2: a packing
//! enlarged λ times about an origin (x' = o + λ(x − o), r' = λr) keeps its contact fabric,
//! since every branch vector l' = λl (eq. 3); with Kn, Ks ∝ d (Kn/Ks fixed) it keeps its
//! macro elasticity too.
//!
//! Why the law is what it is. Stress is force over area, area ∝ λ², so equal stresses need
//! every force ∝ λ²; equal strains need every displacement (overlaps, shear springs,
//! breaking displacement) ∝ λ. Hence:
//! - Kn' = λ·Kn, Ks' = λ·Ks (a force λ² over a displacement λ), so Kn/Ks is unchanged;
//! - Xb' = λ·Xb (a displacement), the breaking force Kn'·Xb' = λ²·Kn·Xb;
//! - Fs0' = λ²·Fs0 (a force); μp is a ratio of forces, unchanged;
//! - Hertz: F = (4/3)·E*·√R*·δ^(3/2) → E*·√(λR*)·(λδ)^(3/2) = λ²·F with E and ν unchanged
//!   (a modulus is a stress); paper 000's E = Kn/(πR) is scale-free for the same reason;
//!   Mindlin's shear stiffness 8·G*·√(R*·δ) ∝ λ, as Ks;
//! - density unchanged, so masses ∝ λ³ and element periods √(m/k) ∝ λ: the time step and
//!   time scale by λ, velocities are unchanged, and a dynamic run is similar if gravity is
//!   divided by λ (body forces ∝ λ³ against contact forces ∝ λ²). The copy keeps the
//!   model's gravity: a model under gravity is similar only without it, as in the paper's
//!   small-strain tests, which are run without gravity.

use crate::error::{Error, Result};
use crate::materials::Material;
use crate::model::Model;
use crate::physics::Vec3;
use crate::walls::WallShape;

/// A material for elements λ times larger, by the scaling law above: Kn, Ks, Xb × λ,
/// Fs0 × λ², μp, E, ν, density and restitution unchanged. Refuses λ that is not a finite
/// number > 0.
pub fn scaled_material(m: &Material, lambda: f64) -> Result<Material> {
    check_lambda(lambda)?;
    m.rescaled(1.0, lambda)
}

fn check_lambda(lambda: f64) -> Result<f64> {
    if !(lambda.is_finite() && lambda > 0.0) {
        return Err(Error::param(
            "lambda",
            lambda,
            "the scale factor must be a finite number > 0 (2 doubles every length; 0.5 halves it)",
        ));
    }
    Ok(lambda)
}

/// The model enlarged `lambda` times about `origin`, keeping its fabric: positions, radii,
/// walls, neighbour rows (the same pairs, in the same order) and per-pair state.
///
/// With `scale_materials` every material follows the scaling law ([`scaled_material`]),
/// and the copy is mechanically similar to the original: the same stresses and strains,
/// forces × λ², the time step and clock × λ. Without it the materials are kept (the paper's
/// "unscaled stiffness" control, Table 1 #2, #3): a linear contact then carries forces × λ
/// only, and the macro stiffness falls by λ.
pub fn scaled_model(m: &Model, lambda: f64, origin: Vec3, scale_materials: bool) -> Result<Model> {
    check_lambda(lambda)?;
    if !origin.iter().all(|v| v.is_finite()) {
        return Err(Error::InvalidScene(format!("the scaling origin {origin:?} must be finite")));
    }
    let l = lambda;
    // Normal and shear force factors of a contact whose overlap and shear displacement grew
    // by λ: λ² under the law; with kept materials a linear spring gives λ, while Hertz and
    // Mindlin (whose stiffness grows with √(R·δ)) still give λ².
    let power = |kept: i32| if scale_materials { 2 } else { kept };
    let f_normal = l.powi(power(m.settings.normal.force_power()));
    let f_shear = l.powi(power(m.settings.tangential.force_power()));
    // Element stiffness (what the time step is set from) grows as the normal force over λ.
    let k_factor = f_normal / l;
    let dt_factor = (l * l * l / k_factor).sqrt();
    let at = |x: &Vec3| origin + (x - origin) * l;

    let mut out = m.clone();
    if scale_materials {
        out.materials = m.materials.iter().map(|mat| scaled_material(mat, l)).collect::<Result<_>>()?;
    }
    let p = &mut out.particles;
    for x in p.pos.iter_mut().chain(p.origin.iter_mut()) {
        *x = at(x);
    }
    for r in &mut p.radius {
        *r *= l;
    }
    for mass in &mut p.mass {
        *mass *= l * l * l;
    }
    for f in &mut p.force {
        *f *= f_normal;
    }
    if let Some(rot) = &mut p.rotation {
        // v = ω·r is unchanged, so ω ∝ 1/λ; torques are forces × λ.
        for w in &mut rot.ang_vel {
            *w /= l;
        }
        for t in &mut rot.torque {
            *t *= f_shear * l;
        }
    }
    // Energies are forces × displacements.
    for lane in p.heat.lanes_mut() {
        for e in lane.iter_mut() {
            *e *= f_normal * l;
        }
    }
    // Applied loads as the contacts' forces (× f_normal, torques × f_normal·λ), their work to
    // date as the heat (× f_normal·λ): each offset set so that the element's work at its new
    // position is the original's scaled (angles are kept).
    let e = f_normal * l;
    if p.applied.allocated(p.len()) {
        for i in 0..p.len() {
            let (was, angle) = (&m.particles, p.angle(i));
            let work = was.applied.work_at(i, &was.pos[i], &angle);
            let a = &mut p.applied;
            a.force[i] *= f_normal;
            a.torque[i] *= e;
            a.offset[i] = e * work - a.force[i].dot(&p.pos[i]) - a.torque[i].dot(&angle);
        }
    }
    p.applied.booked *= e;
    for s in out.contacts.state.iter_mut().chain(out.wall_contacts.iter_mut()) {
        s.shear *= f_shear;
        s.dashpot = (s.dashpot as f64 * f_normal) as f32;
    }
    for x in &mut out.contacts.built_at {
        *x = at(x);
    }
    out.contacts.skin *= l;
    for shape in &mut out.contacts.walls_at_build {
        scale_shape(shape, l, &at);
    }
    for w in &mut out.walls {
        scale_shape(&mut w.shape, l, &at);
        w.area *= l * l;
        w.force *= f_normal;
        w.normal_force *= f_normal;
        w.stiffness *= k_factor;
        w.displacement *= l;
    }
    out.clock.dt *= dt_factor;
    out.clock.time *= dt_factor;
    for b in &mut out.breakages {
        b.time *= dt_factor;
    }
    out.revision += 1;
    Ok(out)
}

fn scale_shape(shape: &mut WallShape, l: f64, at: &impl Fn(&Vec3) -> Vec3) {
    match shape {
        WallShape::Plane { point, .. } => *point = at(point),
        WallShape::Cylinder { center, radius } => {
            *center = at(center);
            *radius *= l;
        }
        WallShape::Cone { apex, radius, rod_length, .. } => {
            *apex = at(apex);
            *radius *= l;
            *rod_length *= l;
        }
        WallShape::Strip { point, lo, hi, .. } => {
            *point = at(point);
            *lo *= l;
            *hi *= l;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::MacroProperties;

    #[test]
    fn scaled_material_follows_the_law_and_keeps_lattice_macro_properties() {
        let p =
            MacroProperties { young: 5e10, poisson: 0.15, tensile: 1e7, compressive: 1.5e8, internal_friction: 1.0 };
        let m = Material::from_macro("granite", 2650.0, &p, 2e-3).unwrap();
        let s = scaled_material(&m, 3.0).unwrap();
        assert!((s.kn / m.kn - 3.0).abs() < 1e-12 && (s.ks / m.ks - 3.0).abs() < 1e-12);
        assert!((s.xb / m.xb - 3.0).abs() < 1e-12 && (s.fs0 / m.fs0 - 9.0).abs() < 1e-12);
        assert_eq!((s.mu_p, s.young, s.poisson, s.density), (m.mu_p, m.young, m.poisson, m.density));
        let (a, b) = (m.lattice_macro(2e-3), s.lattice_macro(6e-3));
        for (x, y) in
            [(a.young, b.young), (a.poisson, b.poisson), (a.tensile, b.tensile), (a.compressive, b.compressive)]
        {
            assert!(((x - y) / x).abs() < 1e-12, "{x} vs {y}");
        }
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = scaled_material(&m, bad).unwrap_err().to_string();
            assert!(e.contains("finite number > 0"), "{e}");
        }
    }
}
