//! Regular packings and the shapes cut from them (MatDEM's `mfs.makeBox`, `makeColumn`,
//! `makeRing`, `makeDisc`, `makeSphere`): elements of one diameter on a lattice, kept where
//! the whole element lies inside the shape.
//!
//! FCC and HCP are the two close packings (74 % solid); FCC is what the macro ↔ micro
//! formulas of paper 003 are derived for, so it is the default. Close-packed layers are
//! stacked along z in both (z is FCC's [111]).

use super::ElementSet;
use crate::builder::{fcc_111_block, simple_cubic, MAX_BOX_PARTICLES};
use crate::error::{check_positive, Error, Result};
use crate::physics::Vec3;
use std::str::FromStr;

/// Which lattice.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LatticeKind {
    /// Face-centred cubic, close-packed layers ABC along z.
    Fcc,
    /// Hexagonal close-packed, layers AB along z.
    Hcp,
    /// Simple cubic (52 % solid): every element touches six.
    Sc,
}

impl FromStr for LatticeKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "fcc" => Ok(LatticeKind::Fcc),
            "hcp" => Ok(LatticeKind::Hcp),
            "sc" => Ok(LatticeKind::Sc),
            _ => Err(Error::unknown("lattice", s, &["fcc", "hcp", "sc"])),
        }
    }
}

impl LatticeKind {
    /// Spacing of rows (y) and of layers (z) for diameter `d`; x spacing is `d`.
    fn spacing(self, d: f64) -> (f64, f64) {
        match self {
            LatticeKind::Fcc | LatticeKind::Hcp => (d * 3f64.sqrt() / 2.0, d * (2.0f64 / 3.0).sqrt()),
            LatticeKind::Sc => (d, d),
        }
    }
}

/// Centres of an `nx` × `ny` × `nz` lattice of diameter `d` (elements per row × rows per
/// layer × layers), the first at the origin. FCC is [`fcc_111_block`].
pub fn lattice(kind: LatticeKind, nx: usize, ny: usize, nz: usize, d: f64) -> Result<Vec<Vec3>> {
    check_positive("diameter", d, false)?;
    let count = nx.checked_mul(ny).and_then(|n| n.checked_mul(nz)).unwrap_or(usize::MAX);
    if count > MAX_BOX_PARTICLES {
        return Err(Error::InvalidScene(format!(
            "a {nx} × {ny} × {nz} lattice has {count} elements, more than the {MAX_BOX_PARTICLES} a model may hold"
        )));
    }
    Ok(match kind {
        LatticeKind::Fcc => fcc_111_block(nx, ny, nz, d),
        LatticeKind::Sc => simple_cubic(nx, ny, nz, d, Vec3::zeros()),
        LatticeKind::Hcp => {
            let (row, layer_h) = kind.spacing(d);
            let mut out = Vec::with_capacity(count);
            for k in 0..nz {
                // B layers sit over the triangle centres of the A layer below.
                let (sx, sy) = if k % 2 == 1 { (d / 2.0, row / 3.0) } else { (0.0, 0.0) };
                for j in 0..ny {
                    for i in 0..nx {
                        let x = i as f64 * d + if j % 2 == 1 { d / 2.0 } else { 0.0 } + sx;
                        out.push(Vec3::new(x, j as f64 * row + sy, k as f64 * layer_h));
                    }
                }
            }
            out
        }
    })
}

/// Elements of diameter `d` on a lattice covering [`lo`, `hi`], kept where `inside(centre)`.
/// The lattice's first layer lies at `lo.z + d/2`, so a flat-bottomed shape is filled from
/// its floor; it starts one row and one element before `lo` so that the offset rows and
/// layers of a close packing fill the low sides too.
fn fill(kind: LatticeKind, d: f64, lo: Vec3, hi: Vec3, inside: impl Fn(&Vec3) -> bool) -> Result<ElementSet> {
    let (row, layer_h) = kind.spacing(d);
    let span = hi - lo;
    // Saturating: a huge shape becomes a count the lattice refuses, not a wrapped small one.
    let count = |len: f64, step: f64| ((len / step).ceil() as usize).saturating_add(3);
    let (nx, ny, nz) = (count(span.x, d), count(span.y, row), count(span.z, layer_h));
    let origin = lo + Vec3::new(d / 2.0 - d, d / 2.0 - row, d / 2.0);
    let centres = lattice(kind, nx, ny, nz, d)?.into_iter().map(|p| p + origin).filter(|p| inside(p)).collect();
    ElementSet::uniform(centres, d / 2.0)
}

/// A float margin so that elements touching a face exactly are kept.
fn slack(r: f64) -> f64 {
    1e-9 * r
}

/// A box [0, w] × [0, l] × [0, h] (m) filled with elements of radius `r`. A length of 0
/// makes a 2D box ([`make_box_2d`]), as MatDEM's `sampleL = 0`.
pub fn make_box(w: f64, l: f64, h: f64, r: f64, kind: LatticeKind) -> Result<ElementSet> {
    if l == 0.0 {
        return make_box_2d(w, h, r, kind);
    }
    for (name, v) in [("width", w), ("length", l), ("height", h), ("element radius", r)] {
        check_positive(name, v, false)?;
    }
    let hi = Vec3::new(w, l, h);
    let e = slack(r);
    fill(kind, 2.0 * r, Vec3::zeros(), hi, |p| (0..3).all(|k| p[k] >= r - e && p[k] <= hi[k] - r + e))
}

/// A 2D box [0, w] × [0, h] (m) in the x–z plane (every centre at y = 0): one close-packed
/// layer of elements of radius `r` (FCC and HCP: hexagonal, rows along x spaced √3/2·d in z,
/// every other row shifted by d/2; SC: square), every element whole inside.
pub fn make_box_2d(w: f64, h: f64, r: f64, kind: LatticeKind) -> Result<ElementSet> {
    for (name, v) in [("width", w), ("height", h), ("element radius", r)] {
        check_positive(name, v, false)?;
    }
    let d = 2.0 * r;
    let (row, shift) = match kind {
        LatticeKind::Fcc | LatticeKind::Hcp => (d * 3f64.sqrt() / 2.0, d / 2.0),
        LatticeKind::Sc => (d, 0.0),
    };
    let (nx, nz) = ((w / d) as usize + 1, ((h - d).max(0.0) / row) as usize + 1);
    if nx.saturating_mul(nz) > MAX_BOX_PARTICLES {
        return Err(Error::InvalidScene(format!(
            "a {w} × {h} m 2D box of radius {r} holds about {} elements, more than the {MAX_BOX_PARTICLES} a model may hold",
            nx.saturating_mul(nz)
        )));
    }
    let e = slack(r);
    let mut centres = Vec::with_capacity(nx * nz);
    for k in 0..nz {
        let z = r + k as f64 * row;
        for i in 0..nx {
            let x = r + i as f64 * d + if k % 2 == 1 { shift } else { 0.0 };
            if x <= w - r + e && z <= h - r + e {
                centres.push(Vec3::new(x, 0.0, z));
            }
        }
    }
    ElementSet::uniform(centres, r)
}

/// Refuses a ring's radii: not finite, negative, or a wall thinner than one element diameter.
fn check_ring(r_in: f64, r_out: f64, r: f64) -> Result<()> {
    check_positive("inner radius", r_in, true)?;
    for (name, v) in [("outer radius", r_out), ("element radius", r)] {
        check_positive(name, v, false)?;
    }
    if r_out - r_in < 2.0 * r {
        return Err(Error::param(
            "outer radius",
            r_out,
            format!("the wall (outer − inner = {}) must be at least one element diameter ({})", r_out - r_in, 2.0 * r),
        ));
    }
    Ok(())
}

/// A 2D annulus in the x–z plane centred on the origin (every centre at y = 0): the hexagonal
/// (or square) layer of [`make_box_2d`] kept where an element lies whole between radii `r_in`
/// and `r_out` (a 2D tunnel's lining; `r_in` = 0: a full circle).
pub fn make_annulus_2d(r_in: f64, r_out: f64, r: f64, kind: LatticeKind) -> Result<ElementSet> {
    check_ring(r_in, r_out, r)?;
    let square = make_box_2d(2.0 * r_out, 2.0 * r_out, r, kind)?;
    let e = slack(r);
    let keep: Vec<bool> = square
        .pos()
        .iter()
        .map(|p| {
            let rho = (p.x - r_out).hypot(p.z - r_out);
            rho <= r_out - r + e && (r_in == 0.0 || rho >= r_in + r - e)
        })
        .collect();
    square.filtered(&keep)?.translated(Vec3::new(-r_out, 0.0, -r_out))
}

/// A vertical column of radius `radius` on the z axis, z in [0, h].
pub fn make_column(radius: f64, h: f64, r: f64, kind: LatticeKind) -> Result<ElementSet> {
    make_ring(0.0, radius, h, r, kind)
}

/// A vertical ring (tube) between radii `r_in` and `r_out` on the z axis, z in [0, h].
pub fn make_ring(r_in: f64, r_out: f64, h: f64, r: f64, kind: LatticeKind) -> Result<ElementSet> {
    check_ring(r_in, r_out, r)?;
    check_positive("height", h, false)?;
    let e = slack(r);
    let (lo, hi) = (Vec3::new(-r_out, -r_out, 0.0), Vec3::new(r_out, r_out, h));
    fill(kind, 2.0 * r, lo, hi, |p| {
        let rho = p.x.hypot(p.y);
        rho <= r_out - r + e && (r_in == 0.0 || rho >= r_in + r - e) && p.z >= r - e && p.z <= h - r + e
    })
}

/// A flat disc of radius `radius`: one close-packed layer centred on the origin at z = 0.
pub fn make_disc(radius: f64, r: f64) -> Result<ElementSet> {
    check_positive("disc radius", radius, false)?;
    check_positive("element radius", r, false)?;
    let e = slack(r);
    let lo = Vec3::new(-radius, -radius, -r);
    let centres = fill(LatticeKind::Fcc, 2.0 * r, lo, Vec3::new(radius, radius, r), |p| {
        p.z.abs() <= e && p.x.hypot(p.y) <= radius - r + e
    })?;
    Ok(centres)
}

/// A ball of radius `radius` centred on the origin.
pub fn make_sphere(radius: f64, r: f64, kind: LatticeKind) -> Result<ElementSet> {
    check_positive("sphere radius", radius, false)?;
    check_positive("element radius", r, false)?;
    let e = slack(r);
    let c = Vec3::repeat(radius);
    fill(kind, 2.0 * r, -c, c, |p| p.norm() <= radius - r + e)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Solid fraction of a close packing, π/(3√2).
    const CLOSE_PACKED: f64 = 0.740_480_489_693_061;

    fn min_gap(s: &ElementSet) -> f64 {
        let (p, r) = (s.pos(), s.radius());
        let mut g = f64::INFINITY;
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                g = g.min((p[j] - p[i]).norm() - r[i] - r[j]);
            }
        }
        g
    }

    #[test]
    fn lattices_touch_without_overlap() {
        for kind in [LatticeKind::Fcc, LatticeKind::Hcp, LatticeKind::Sc] {
            let s = ElementSet::uniform(lattice(kind, 4, 4, 4, 1.0).unwrap(), 0.5).unwrap();
            assert!(min_gap(&s).abs() < 1e-12, "{kind:?}: {}", min_gap(&s));
        }
    }

    #[test]
    fn a_large_close_packed_box_approaches_the_close_packed_solid_fraction() {
        // 40 diameters a side: the loose fit against the six faces costs about 5 %.
        let s = make_box(40.0, 40.0, 40.0, 0.5, LatticeKind::Fcc).unwrap();
        let solid = s.len() as f64 * std::f64::consts::PI / 6.0 / 40f64.powi(3);
        assert!(solid > 0.93 * CLOSE_PACKED && solid < CLOSE_PACKED, "{solid}");
        let (lo, hi) = s.bounds().unwrap();
        assert!(lo.min() >= -1e-9 && hi.max() <= 40.0 + 1e-9, "{lo} {hi}");
    }

    /// A 2D box's hexagonal layer: every element touches its neighbours and none overlaps,
    /// interior elements touch six, and a large one fills π/(2√3) of its area.
    #[test]
    fn a_2d_box_is_one_hexagonal_layer_in_the_xz_plane() {
        let s = make_box(30.0, 0.0, 30.0, 0.5, LatticeKind::Fcc).unwrap();
        assert!(s.pos().iter().all(|p| p.y == 0.0));
        assert!(min_gap(&s).abs() < 1e-12, "{}", min_gap(&s));
        let touching = |i: usize| s.pos().iter().filter(|q| ((*q - s.pos()[i]).norm() - 1.0).abs() < 1e-9).count();
        let centre = s.pos().iter().position(|p| (p.x - 15.0).abs() < 0.6 && (p.z - 15.0).abs() < 0.5).unwrap();
        assert_eq!(touching(centre), 6);
        let solid = s.len() as f64 * std::f64::consts::PI * 0.25 / (30.0 * 30.0);
        let hexagonal = std::f64::consts::PI / (2.0 * 3f64.sqrt());
        assert!(solid > 0.93 * hexagonal && solid < hexagonal, "{solid}");
        let (lo, hi) = s.bounds().unwrap();
        assert!(lo.x >= -1e-9 && lo.z >= -1e-9 && hi.x <= 30.0 + 1e-9 && hi.z <= 30.0 + 1e-9, "{lo} {hi}");
    }

    #[test]
    fn a_2d_annulus_holds_its_elements_whole_in_the_plane() {
        let ring = make_annulus_2d(3.0, 6.0, 0.5, LatticeKind::Fcc).unwrap();
        assert!(ring.len() > 50);
        for p in ring.pos() {
            let rho = p.x.hypot(p.z);
            assert!(p.y == 0.0 && (3.5 - 1e-9..=5.5 + 1e-9).contains(&rho), "{p}");
        }
        let circle = make_annulus_2d(0.0, 6.0, 0.5, LatticeKind::Fcc).unwrap();
        assert!(circle.len() > ring.len() && circle.pos().iter().all(|p| p.x.hypot(p.z) <= 5.5 + 1e-9));
        assert!(make_annulus_2d(3.0, 3.5, 0.5, LatticeKind::Fcc).is_err());
    }

    #[test]
    fn shapes_hold_their_elements_whole() {
        let ring = make_ring(3.0, 6.0, 4.0, 0.5, LatticeKind::Hcp).unwrap();
        for p in ring.pos() {
            let rho = p.x.hypot(p.y);
            assert!((3.5 - 1e-9..=5.5 + 1e-9).contains(&rho) && p.z >= 0.5 - 1e-9 && p.z <= 3.5 + 1e-9);
        }
        let ball = make_sphere(5.0, 0.5, LatticeKind::Fcc).unwrap();
        assert!(ball.pos().iter().all(|p| p.norm() <= 4.5 + 1e-9));
        let disc = make_disc(5.0, 0.5).unwrap();
        assert!(disc.pos().iter().all(|p| p.z == 0.0 && p.x.hypot(p.y) <= 4.5 + 1e-9));
        // A disc is a hexagonal layer: about π·4.5² / (√3/2) elements.
        let expected = std::f64::consts::PI * 4.5 * 4.5 / (3f64.sqrt() / 2.0);
        assert!((disc.len() as f64 / expected - 1.0).abs() < 0.15, "{} vs {expected}", disc.len());
        assert!(make_ring(3.0, 3.5, 4.0, 0.5, LatticeKind::Fcc).is_err());
    }
}
