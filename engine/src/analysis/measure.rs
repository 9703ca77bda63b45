//! Measurements in a region: the mean stress by Love–Weber, the porosity and the
//! coordination number; and the strain of a region's elements between a reference state and
//! now, from the best-fit (least-squares) displacement gradient.
//!
//! **Stress** (Love 1927, Weber 1966; Christoffersen, Mehrabadi & Nemat-Nasser 1981):
//! σ_ij = −(1/V)·Σ_c w_c·f_i^c·l_j^c over the contacts c, f^c the force on the contact's first
//! element, l^c its branch vector (from that element's centre to the other's, or to the
//! contact point on a wall's surface), V the region's volume; compression positive, as the
//! walls' stresses. **A contact cut by the region's boundary counts by its share w_c, the
//! fraction of its branch vector that lies inside the region** (1 inside, 0 outside). With
//! this rule the force a horizontal plane cuts through the branches is the load above it, so
//! at equilibrium and without body forces σzz of a slab across a box with frictionless sides
//! is the platen's stress exactly, whatever the slab's height; and over a region of whole
//! lattice periods the shares add up to the lattice's mean exactly. The tensor is returned
//! symmetrised (its antisymmetric part is the region's unbalanced moment, zero at equilibrium).
//! In a periodic cell a branch that reaches out through a face comes back through the other
//! (its images' shares add), so a region that is the whole cell counts every contact whole and
//! gives the cell's stress, as the infinite lattice's for a strained periodic lattice.
//! Porosity is by exact volumes (`status::porosity`); the coordination number counts the
//! contacts of the elements whose centre is inside, as `fabric` does.
//!
//! **Strain**: F = (Σ_p x'_p ⊗ X'_p)·(Σ_p X'_p ⊗ X'_p)⁻¹ minimises Σ_p |x'_p − F·X'_p|² (X'
//! the reference positions, x' the current ones, both about their centroids), and the strain
//! is Green–Lagrange's, E = ½(FᵀF − I), reported compression positive (−E): exact for an
//! affine deformation, zero for a rigid rotation of any size. Its volumetric part is tr(−E),
//! its deviatoric part −E − tr(−E)/3·I; det F − 1 is the volume change.

use super::contact_list::{ContactList, Other};
use super::fabric::{elements_inside, principal};
use crate::error::{Error, Result};
use crate::model::Model;
use crate::physics::Vec3;
use crate::status::{porosity, Region};
use nalgebra::Matrix3;

/// What `measure` found in a region.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Mean stress tensor (Pa), compression positive, symmetrised.
    pub stress: Matrix3<f64>,
    /// Principal stresses (Pa), largest first, and their unit directions.
    pub principal_stress: [f64; 3],
    pub principal_directions: [Vec3; 3],
    /// p = tr(σ)/3 (Pa).
    pub mean_stress: f64,
    /// q = √(3/2·s:s), s = σ − p·I (Pa).
    pub deviator_stress: f64,
    /// 1 − (the volume the elements share with the region) / its volume (exact volumes).
    pub porosity: f64,
    /// Mean contacts per element whose centre is inside (pairs only, as `fabric`).
    pub coordination: f64,
    /// Elements whose centre is inside.
    pub elements: usize,
    /// The region's volume (m³).
    pub volume: f64,
}

/// Measures `region` (see the module's docs for the rules).
pub fn measure(m: &Model, list: &ContactList, region: &Region) -> Result<Measurement> {
    // A 2D model's region is its cut by the plane times the thickness.
    let volume = m.region_volume(region);
    if !(volume > 0.0 && volume.is_finite()) {
        return Err(Error::InvalidScene(format!("measure: the region's volume is {volume} m³; give it a size > 0")));
    }
    let inside = elements_inside(m, Some(region));
    let elements = inside.iter().filter(|b| **b).count();
    if elements == 0 {
        return Err(Error::InvalidScene(
            "measure: no element has its centre in the region; enlarge it or move it into the packing".into(),
        ));
    }
    let mut sum = Matrix3::zeros();
    let mut contacts = 0.0;
    let p = &m.particles;
    // In a periodic cell a branch reaching out through a face comes in through the other.
    let shifts = m.effects.periodic.cell.map_or_else(|| vec![Vec3::zeros()], |c| c.image_shifts());
    for row in list.rows.iter().filter(|r| r.is_active()) {
        let x = p.pos[row.i as usize];
        let share: f64 = shifts.iter().map(|s| region.segment_share(x + s, x + s + row.branch)).sum();
        if share > 0.0 {
            sum += row.force * row.branch.transpose() * share;
        }
        if let Other::Element(j) = row.other {
            contacts += f64::from(u8::from(inside[row.i as usize]) + u8::from(inside[j as usize]));
        }
    }
    let raw = -sum / volume;
    let stress = (raw + raw.transpose()) * 0.5;
    let mean_stress = stress.trace() / 3.0;
    let dev = stress - Matrix3::identity() * mean_stress;
    let (principal_stress, principal_directions) = principal(&stress);
    Ok(Measurement {
        stress,
        principal_stress,
        principal_directions,
        mean_stress,
        deviator_stress: (1.5 * dev.component_mul(&dev).sum()).sqrt(),
        porosity: porosity(m, region),
        coordination: contacts / elements as f64,
        elements,
        volume,
    })
}

/// The strain of a set of elements between two states.
#[derive(Debug, Clone, PartialEq)]
pub struct Strain {
    /// The best-fit deformation gradient F (dimensionless).
    pub deformation_gradient: Matrix3<f64>,
    /// Green–Lagrange strain, compression positive: −½(FᵀF − I).
    pub strain: Matrix3<f64>,
    /// tr(strain): compression positive.
    pub volumetric: f64,
    /// strain − volumetric/3·I.
    pub deviatoric: Matrix3<f64>,
    /// √(2/3·e:e) of the deviatoric part e (the equivalent shear strain).
    pub deviatoric_equivalent: f64,
    /// det F − 1: the relative volume change (negative when the region shrinks).
    pub volume_change: f64,
    /// Root mean square of the fit's residual displacements (m): 0 for an affine motion.
    pub residual: f64,
    /// Elements fitted.
    pub elements: usize,
}

/// The strain of the elements `selected` between their positions `reference` and `current`
/// (see the module's docs). Needs four or more elements not all in one plane.
pub fn strain(reference: &[Vec3], current: &[Vec3], selected: &[bool]) -> Result<Strain> {
    let ids: Vec<usize> = (0..selected.len()).filter(|&i| selected[i]).collect();
    if reference.len() != current.len() || selected.len() != current.len() {
        return Err(Error::InvalidScene(format!(
            "strain: the reference state has {} elements, the model {}; measure against a state of the same model \
             (taken before elements were added or deleted)",
            reference.len(),
            current.len()
        )));
    }
    if ids.len() < 4 {
        return Err(Error::InvalidScene(format!(
            "strain: {} element(s) in the region; a displacement gradient needs at least 4 not in one plane",
            ids.len()
        )));
    }
    let k = ids.len() as f64;
    let c0: Vec3 = ids.iter().map(|&i| reference[i]).sum::<Vec3>() / k;
    let c1: Vec3 = ids.iter().map(|&i| current[i]).sum::<Vec3>() / k;
    let (mut xx, mut yx) = (Matrix3::zeros(), Matrix3::zeros());
    for &i in &ids {
        let (a, b) = (reference[i] - c0, current[i] - c1);
        xx += a * a.transpose();
        yx += b * a.transpose();
    }
    // A set in one plane (or on a line) has a singular second moment: its gradient out of
    // that plane is undetermined.
    let (moments, _) = principal(&xx);
    if moments[2].is_nan() || moments[2] <= 1e-12 * moments[0] {
        return Err(Error::InvalidScene(format!(
            "strain: the {} elements of the region lie in one plane (or on a line) in the reference state, so the \
             displacement gradient across it is undetermined; use a region that holds a 3-D set of elements",
            ids.len()
        )));
    }
    let inv = xx.try_inverse().ok_or_else(|| Error::InvalidScene("strain: singular reference moments".into()))?;
    let f = yx * inv;
    let e = (f.transpose() * f - Matrix3::identity()) * -0.5;
    let volumetric = e.trace();
    let deviatoric = e - Matrix3::identity() * (volumetric / 3.0);
    let residual =
        (ids.iter().map(|&i| ((current[i] - c1) - f * (reference[i] - c0)).norm_squared()).sum::<f64>() / k).sqrt();
    Ok(Strain {
        deformation_gradient: f,
        strain: e,
        volumetric,
        deviatoric,
        deviatoric_equivalent: (2.0 / 3.0 * deviatoric.component_mul(&deviatoric).sum()).sqrt(),
        volume_change: f.determinant() - 1.0,
        residual,
        elements: ids.len(),
    })
}
