//! A periodic cell's setting and its arithmetic: which axes repeat, over what span, the
//! minimum-image separation and the wrap back into the cell. Kept apart from `mod.rs` (which
//! holds the model's calls) so that the settings and the hot loops can name it without naming
//! [`crate::model::Model`].

use crate::physics::Vec3;
use serde::{Deserialize, Serialize};

/// The axes that repeat, each with its span `[lo, hi)` (m); `None`: not periodic.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Periodic {
    pub axes: [Option<[f64; 2]>; 3],
}

impl Periodic {
    /// The image arithmetic the hot loops use.
    pub fn image(&self) -> Image {
        let span = |k: usize| self.axes[k].map_or(0.0, |[lo, hi]| hi - lo);
        let len = Vec3::new(span(0), span(1), span(2));
        let inv = len.map(|l| if l > 0.0 { 1.0 / l } else { 0.0 });
        Image { len, inv }
    }

    /// The axes' letters and spans, as the plan words them.
    pub fn words(&self) -> String {
        let axes: Vec<String> = ["x", "y", "z"]
            .iter()
            .zip(&self.axes)
            .filter_map(|(n, a)| a.map(|[lo, hi]| format!("{n} ∈ [{lo:.4e}, {hi:.4e})")))
            .collect();
        format!("periodic({})", axes.join(", "))
    }
}

/// Minimum-image arithmetic: spans `len` (0 on an axis that does not repeat) and their
/// inverses (0 there too), so that one expression serves every axis without a branch.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Image {
    pub len: Vec3,
    pub inv: Vec3,
}

impl Image {
    /// The shortest of the separations `d + k·len` (k whole): the one a pair interacts through.
    #[inline(always)]
    pub fn nearest(&self, d: Vec3) -> Vec3 {
        d - self.len.component_mul(&d.component_mul(&self.inv).map(f64::round))
    }
}

impl Periodic {
    /// Puts `x` back into the cell; returns the shift it took (add it to anything that must
    /// move with the element, such as its displacement's origin). Exact: a span added or taken
    /// once, so an element that crosses a face keeps its offset from the face to round-off.
    #[inline]
    pub fn wrap(&self, x: &mut Vec3) -> Vec3 {
        let mut shift = Vec3::zeros();
        for (k, axis) in self.axes.iter().enumerate() {
            if let Some([lo, hi]) = *axis {
                let l = hi - lo;
                if x[k] < lo {
                    shift[k] = l * ((lo - x[k]) / l).ceil();
                } else if x[k] >= hi {
                    shift[k] = -l * ((x[k] - hi) / l + 1.0).floor();
                }
                x[k] += shift[k];
            }
        }
        shift
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell() -> Periodic {
        Periodic { axes: [Some([0.0, 1.0]), None, Some([-2.0, 2.0])] }
    }

    #[test]
    fn the_nearest_image_is_within_half_a_span_on_periodic_axes_only() {
        let im = cell().image();
        let d = im.nearest(Vec3::new(0.9, 5.0, -3.5));
        assert!((d - Vec3::new(-0.1, 5.0, 0.5)).norm() < 1e-15, "{d:?}");
    }

    #[test]
    fn a_wrap_brings_an_element_back_and_says_by_how_much() {
        let p = cell();
        let mut x = Vec3::new(1.25, 7.0, -2.5);
        let s = p.wrap(&mut x);
        assert_eq!(s, Vec3::new(-1.0, 0.0, 4.0));
        assert!((x - Vec3::new(0.25, 7.0, 1.5)).norm() < 1e-15);
        let mut inside = Vec3::new(0.0, 0.0, -2.0);
        assert_eq!(p.wrap(&mut inside), Vec3::zeros());
    }
}
