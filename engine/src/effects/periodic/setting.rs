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
    /// Lees–Edwards shear of the cell (x and z periodic): x flows, z is the gradient.
    pub shear: Option<Shear>,
}

/// Lees–Edwards simple shear: the cell's image above (z + L_z) slides along x at γ̇·L_z, so a
/// periodic packing shears homogeneously at γ̇ with no walls at all.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Shear {
    /// γ̇ (1/s).
    pub rate: f64,
    /// How far the image above has slid along x (m), in [0, L_x).
    pub offset: f64,
    /// The offset when the rows were last built: how far it may move before they must be
    /// built again (a pair across the z faces is brought closer by the slide).
    pub offset_at_build: f64,
}

impl Periodic {
    /// The image arithmetic the hot loops use.
    pub fn image(&self) -> Image {
        let span = |k: usize| self.axes[k].map_or(0.0, |[lo, hi]| hi - lo);
        let len = Vec3::new(span(0), span(1), span(2));
        let inv = len.map(|l| if l > 0.0 { 1.0 / l } else { 0.0 });
        let (shift, slide) = self.shear.map_or((0.0, 0.0), |s| (s.offset, s.rate * len.z));
        Image { len, inv, shift, slide }
    }

    /// How far the slide has moved the images across the z faces since the rows were built
    /// (m; 0 without shear).
    pub fn slip_since_build(&self) -> f64 {
        match (self.shear, self.axes[0]) {
            (Some(s), Some([lo, hi])) => {
                let d = (s.offset - s.offset_at_build).rem_euclid(hi - lo);
                d.min(hi - lo - d)
            }
            _ => 0.0,
        }
    }

    /// Where the images of a point nearest the cell lie, as shifts from it: every combination
    /// of −1, 0 and +1 spans along the periodic axes (the zero shift first), the image k cells
    /// up along z also `k·offset` along x under Lees–Edwards shear. A measurement region within
    /// the cell meets a sphere or a contact reaching out through a face at one of these.
    pub fn image_shifts(&self) -> Vec<Vec3> {
        let image = self.image();
        let steps = |k: usize| if image.len[k] > 0.0 { vec![0.0, -1.0, 1.0] } else { vec![0.0] };
        let mut out = Vec::with_capacity(27);
        for &kz in &steps(2) {
            for &ky in &steps(1) {
                for &kx in &steps(0) {
                    let x = kx * image.len.x + kz * image.shift;
                    out.push(Vec3::new(x, ky * image.len.y, kz * image.len.z));
                }
            }
        }
        out
    }

    /// The axes' letters and spans, as the plan words them.
    pub fn words(&self) -> String {
        let axes: Vec<String> = ["x", "y", "z"]
            .iter()
            .zip(&self.axes)
            .filter_map(|(n, a)| a.map(|[lo, hi]| format!("{n} ∈ [{lo:.4e}, {hi:.4e})")))
            .collect();
        match self.shear {
            Some(s) => format!("periodic({}; Lees–Edwards shear γ̇ = {:.4e} 1/s, x along z)", axes.join(", "), s.rate),
            None => format!("periodic({})", axes.join(", ")),
        }
    }
}

/// Minimum-image arithmetic: spans `len` (0 on an axis that does not repeat) and their
/// inverses (0 there too), so that one expression serves every axis without a branch; with
/// Lees–Edwards shear, the images across the z faces shifted along x by `shift` and moving
/// along x at `slide` = γ̇·L_z (both 0 without).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Image {
    pub len: Vec3,
    pub inv: Vec3,
    pub shift: f64,
    pub slide: f64,
}

impl Image {
    /// The shortest of the separations from i to the images of j: the one a pair interacts
    /// through.
    #[inline(always)]
    pub fn nearest(&self, d: Vec3) -> Vec3 {
        self.nearest_sliding(d).0
    }

    /// What [`nearest`](Self::nearest) takes off `d`: the shift from the point at `d` to its
    /// image nearest the origin (whole spans, and k·offset along x for k cells along z).
    #[inline]
    pub fn shift_of(&self, d: Vec3) -> Vec3 {
        let k = (d.z * self.inv.z).round();
        let mut s = d;
        s.x -= k * self.shift;
        let spans = self.len.component_mul(&s.component_mul(&self.inv).map(f64::round));
        Vec3::new(spans.x + k * self.shift, spans.y, spans.z)
    }

    /// The nearest separation `d`, and what a pair's relative velocity v_i − v_j gains through
    /// that image along x: k·γ̇·L_z for the image k cells down (which moves k·γ̇·L_z slower than
    /// j along x).
    #[inline(always)]
    pub fn nearest_sliding(&self, mut d: Vec3) -> (Vec3, f64) {
        let k = (d.z * self.inv.z).round();
        d.x -= k * self.shift;
        (d - self.len.component_mul(&d.component_mul(&self.inv).map(f64::round)), k * self.slide)
    }
}

impl Periodic {
    /// Puts `x` back into the cell; returns the shift it took (add it to anything that must
    /// move with the element, such as its displacement's origin). Exact: a span added or taken
    /// once, so an element that crosses a face keeps its offset from the face to round-off.
    #[inline]
    pub fn wrap(&self, x: &mut Vec3) -> Vec3 {
        self.wrap_sliding(x).0
    }

    /// [`wrap`](Self::wrap) under Lees–Edwards shear: an element that crosses a z face also
    /// moves along x by the images' offset and changes its x velocity by their slide (returned,
    /// to add to it), so that it continues as the image it was.
    #[inline]
    pub fn wrap_sliding(&self, x: &mut Vec3) -> (Vec3, f64) {
        let mut shift = Vec3::zeros();
        let mut kick = 0.0;
        if let (Some(s), Some([lo, hi])) = (self.shear, self.axes[2]) {
            let l = hi - lo;
            // Whole cells crossed downwards (negative: upwards).
            let k = if x.z < lo {
                ((lo - x.z) / l).ceil()
            } else if x.z >= hi {
                -((x.z - hi) / l + 1.0).floor()
            } else {
                0.0
            };
            if k != 0.0 {
                shift.z = k * l;
                shift.x = k * s.offset;
                kick = k * s.rate * l;
                x.z += shift.z;
                x.x += shift.x;
            }
        }
        for (k, axis) in self.axes.iter().enumerate() {
            if let Some([lo, hi]) = *axis {
                let l = hi - lo;
                let s = if x[k] < lo {
                    l * ((lo - x[k]) / l).ceil()
                } else if x[k] >= hi {
                    -l * ((x[k] - hi) / l + 1.0).floor()
                } else {
                    0.0
                };
                if s != 0.0 {
                    x[k] += s;
                    shift[k] += s;
                }
            }
        }
        (shift, kick)
    }
}

/// Pair separations in a model: through the nearest image when it has a periodic cell.
#[derive(Debug, Clone, Copy)]
pub struct Separations(Option<Image>);

impl Separations {
    /// The separations in `cell` (plain differences without one).
    pub fn of(cell: Option<&Periodic>) -> Self {
        Separations(cell.map(Periodic::image))
    }

    /// Whether the model has a periodic cell (else every separation is `pos[j] − pos[i]`).
    pub fn periodic(&self) -> bool {
        self.0.is_some()
    }

    /// From `pos[i]` to `pos[j]`, and the x velocity j's nearest image has beyond j's own under
    /// Lees–Edwards shear (0 otherwise; see [`Image::nearest_sliding`]).
    #[inline(always)]
    pub fn between_sliding(&self, pos: &[Vec3], i: usize, j: usize) -> (Vec3, f64) {
        let d = pos[j] - pos[i];
        match &self.0 {
            Some(image) => {
                let (d, slide) = image.nearest_sliding(d);
                (d, -slide)
            }
            None => (d, 0.0),
        }
    }

    /// From `pos[i]` to `pos[j]`.
    #[inline(always)]
    pub fn between(&self, pos: &[Vec3], i: usize, j: usize) -> Vec3 {
        let d = pos[j] - pos[i];
        match &self.0 {
            Some(image) => image.nearest(d),
            None => d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell() -> Periodic {
        Periodic { axes: [Some([0.0, 1.0]), None, Some([-2.0, 2.0])], shear: None }
    }

    #[test]
    fn the_nearest_image_is_within_half_a_span_on_periodic_axes_only() {
        let im = cell().image();
        let d = im.nearest(Vec3::new(0.9, 5.0, -3.5));
        assert!((d - Vec3::new(-0.1, 5.0, 0.5)).norm() < 1e-15, "{d:?}");
    }

    /// Under shear, the image one cell up sits `offset` further along x and moves `γ̇·L_z`
    /// faster; an element leaving through the top re-enters at the bottom as that image's twin.
    #[test]
    fn the_sheared_images_are_shifted_and_sliding() {
        let p = Periodic { shear: Some(Shear { rate: 2.0, offset: 0.25, offset_at_build: 0.0 }), ..cell() };
        let im = p.image();
        // j 3.9 above i: its image one cell down (k = 1) is 0.25 back along x, moving 8 slower.
        let (d, dv) = im.nearest_sliding(Vec3::new(0.1, 0.0, 3.9));
        assert!((d - Vec3::new(-0.15, 0.0, -0.1)).norm() < 1e-15, "{d:?}");
        assert_eq!(dv, 8.0);
        // What the nearest image took off: one cell up, the offset along.
        assert_eq!(im.shift_of(Vec3::new(0.1, 0.0, 3.9)), Vec3::new(0.25, 0.0, 4.0));
        let mut x = Vec3::new(0.5, 0.0, 2.1);
        let (shift, kick) = p.wrap_sliding(&mut x);
        assert!((x - Vec3::new(0.25, 0.0, -1.9)).norm() < 1e-15 && kick == -8.0, "{x:?} {shift:?} {kick}");
        let mut below = Vec3::new(0.9, 0.0, -2.1);
        let (_, kick) = p.wrap_sliding(&mut below);
        assert!((below - Vec3::new(0.15, 0.0, 1.9)).norm() < 1e-15 && kick == 8.0, "{below:?}");
    }

    #[test]
    fn the_image_shifts_cover_the_neighbouring_cells_once() {
        let p = Periodic { shear: Some(Shear { rate: 2.0, offset: 0.25, offset_at_build: 0.0 }), ..cell() };
        let shifts = p.image_shifts();
        assert_eq!(shifts.len(), 9, "x and z repeat: 3 × 3");
        assert_eq!(shifts[0], Vec3::zeros());
        // One cell up (z + 4) sits the offset further along x, one cell down as far back.
        assert!(shifts.contains(&Vec3::new(0.25, 0.0, 4.0)) && shifts.contains(&Vec3::new(-1.25, 0.0, -4.0)));
        let mut unique = shifts.clone();
        unique.dedup();
        assert_eq!(unique.len(), 9);
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
