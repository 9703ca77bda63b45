//! A set of elements outside any model: MatDEM's geometry objects (`mfs.makeBox` returns one),
//! plain arrays of centres and radii. They are combined, cut and moved as whole arrays, then
//! added to a model in one call; nothing here knows about contacts or materials.

use crate::error::{Error, Result};
use crate::physics::Vec3;

/// Centres (m) and radii (m) of elements, aligned by index. Every centre is finite and
/// every radius finite and > 0 (the constructors check; the transforms keep it so).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ElementSet {
    pos: Vec<Vec3>,
    radius: Vec<f64>,
}

impl ElementSet {
    /// Elements at `pos` with radii `radius`; refuses a length mismatch, a non-finite
    /// coordinate or a radius that is not a finite number > 0, naming the element.
    pub fn new(pos: Vec<Vec3>, radius: Vec<f64>) -> Result<Self> {
        if pos.len() != radius.len() {
            return Err(Error::InvalidScene(format!(
                "an element set needs one radius per centre: {} centres, {} radii",
                pos.len(),
                radius.len()
            )));
        }
        if let Some(i) = pos.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(Error::InvalidScene(format!(
                "element {i} has a centre that is not finite ({}, {}, {})",
                pos[i].x, pos[i].y, pos[i].z
            )));
        }
        if let Some(i) = radius.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
            return Err(Error::InvalidScene(format!(
                "element {i} has radius {}; a radius must be a finite number > 0 m",
                radius[i]
            )));
        }
        Ok(ElementSet { pos, radius })
    }

    /// Elements of one radius at `pos` (`radius` checked by [`ElementSet::new`]).
    pub fn uniform(pos: Vec<Vec3>, radius: f64) -> Result<Self> {
        let n = pos.len();
        Self::new(pos, vec![radius; n])
    }

    pub fn len(&self) -> usize {
        self.pos.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    pub fn pos(&self) -> &[Vec3] {
        &self.pos
    }

    pub fn radius(&self) -> &[f64] {
        &self.radius
    }

    /// The same elements shifted by `shift` (m).
    pub fn translated(&self, shift: Vec3) -> Result<Self> {
        check_finite("shift", shift)?;
        Ok(ElementSet { pos: self.pos.iter().map(|p| p + shift).collect(), radius: self.radius.clone() })
    }

    /// The same elements turned by `angle` (rad, right-handed) about the line through
    /// `centre` along `axis`.
    pub fn rotated(&self, centre: Vec3, axis: Vec3, angle: f64) -> Result<Self> {
        check_finite("centre", centre)?;
        check_finite("axis", axis)?;
        if !angle.is_finite() {
            return Err(Error::param("angle", angle, "must be a finite number"));
        }
        let axis = nalgebra::Unit::try_new(axis, 0.0).ok_or_else(|| {
            Error::InvalidScene("the rotation axis is [0, 0, 0]; give a direction such as [0, 0, 1]".into())
        })?;
        let rot = nalgebra::Rotation3::from_axis_angle(&axis, angle);
        Ok(ElementSet {
            pos: self.pos.iter().map(|p| centre + rot * (p - centre)).collect(),
            radius: self.radius.clone(),
        })
    }

    /// These elements followed by `other`'s (indices of `other` shift by `self.len()`).
    pub fn combined(&self, other: &ElementSet) -> Self {
        let mut out = self.clone();
        out.pos.extend_from_slice(&other.pos);
        out.radius.extend_from_slice(&other.radius);
        out
    }

    /// The elements where `keep` is true, in order; `keep` must have one flag per element.
    pub fn filtered(&self, keep: &[bool]) -> Result<Self> {
        if keep.len() != self.len() {
            return Err(Error::InvalidScene(format!(
                "a filter needs one flag per element: {} flags for {} elements",
                keep.len(),
                self.len()
            )));
        }
        let (pos, radius) =
            self.pos.iter().zip(&self.radius).zip(keep).filter(|(_, k)| **k).map(|((p, r), _)| (*p, *r)).unzip();
        Ok(ElementSet { pos, radius })
    }

    /// The smallest box holding every element whole (centre ± radius); `None` when empty.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self.pos.iter().zip(&self.radius);
        let (p, r) = it.next()?;
        let init = (p - Vec3::repeat(*r), p + Vec3::repeat(*r));
        Some(it.fold(init, |(lo, hi), (p, r)| (lo.inf(&(p - Vec3::repeat(*r))), hi.sup(&(p + Vec3::repeat(*r))))))
    }
}

fn check_finite(name: &'static str, v: Vec3) -> Result<()> {
    match v.iter().find(|c| !c.is_finite()) {
        Some(c) => Err(Error::param(name, *c, "every component must be a finite number")),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quarter_turn_about_z_maps_x_to_y() {
        let s = ElementSet::uniform(vec![Vec3::new(2.0, 1.0, 5.0)], 0.5).unwrap();
        let t = s.rotated(Vec3::new(1.0, 1.0, 0.0), Vec3::z(), std::f64::consts::FRAC_PI_2).unwrap();
        assert!((t.pos()[0] - Vec3::new(1.0, 2.0, 5.0)).norm() < 1e-12);
    }

    #[test]
    fn bad_radii_and_lengths_are_refused_by_index() {
        let e = ElementSet::new(vec![Vec3::zeros(); 2], vec![1.0, -1.0]).unwrap_err().to_string();
        assert!(e.contains("element 1") && e.contains("-1"), "{e}");
        assert!(ElementSet::new(vec![Vec3::zeros(); 2], vec![1.0]).is_err());
        let s = ElementSet::uniform(vec![Vec3::zeros(); 3], 1.0).unwrap();
        assert!(s.filtered(&[true]).is_err());
        assert_eq!(s.filtered(&[true, false, true]).unwrap().len(), 2);
    }
}
