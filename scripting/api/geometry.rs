//! Geometry objects (MatDEM's `mfs`): elements outside any model, as whole arrays of
//! centres and radii, made on a lattice (`make_box`, `make_column`, `make_ring`/`make_tube`,
//! `make_disc`, `make_sphere`, `make_lattice`) or from arrays and tables (`geometry`), then
//! moved, turned, combined and filtered by masks before `d.add_elements(g, material, group)`
//! puts them in a model.
//!
//! A geometry is a value: every operation returns a new one and leaves its input as it was,
//! so `g.copy()` exists only for MatDEM users who expect it. Nothing here reads a model, so
//! nothing is journaled for resume.

use super::arrays::{number, to_numbers, Field, Mask};
use super::table::{Table, TableData};
use super::{err, raise, RhaiResult};
use matdem_engine::geometry::{lattice, ElementSet, LatticeKind};
use matdem_engine::Vec3;
use rhai::{Array, Dynamic, Engine, INT};
use std::rc::Rc;

/// The documentation of every name registered here: (name, usage, what it does).
pub const DOCS: &[(&str, &str, &str)] = &[
    ("make_box", "make_box(w, l, h, ball_r) / make_box(w, l, h, ball_r, \"fcc\" | \"hcp\" | \"sc\") -> Geometry", "a box [0, w] × [0, l] × [0, h] (m) filled with elements of radius ball_r on a lattice (close-packed FCC unless named), every element whole inside (MatDEM mfs.makeBox); l = 0 makes one layer in the x–z plane at y = 0 for a 2D model (hexagonal, or square with \"sc\")"),
    ("make_column", "make_column(radius, h, ball_r) / (…, lattice) -> Geometry", "a vertical column on the z axis, z in [0, h], filled like make_box (MatDEM mfs.makeColumn)"),
    ("make_ring", "make_ring(r_in, r_out, h, ball_r) / (…, lattice) -> Geometry", "a vertical ring (tube wall) between radii r_in and r_out on the z axis, z in [0, h]; the wall must be at least one element diameter thick (MatDEM mfs.makeRing)"),
    ("make_tube", "make_tube(r_in, r_out, h, ball_r) / (…, lattice) -> Geometry", "the same as make_ring"),
    ("make_annulus", "make_annulus(r_in, r_out, ball_r) / (…, lattice) -> Geometry", "a 2D ring in the x–z plane centred on the origin (every centre at y = 0; r_in = 0: a full circle), one close-packed layer, every element whole between the radii: a 2D tunnel's lining, to move and add to a 2D model"),
    ("make_disc", "make_disc(radius, ball_r) -> Geometry", "one close-packed layer of elements in a disc centred on the origin at z = 0 (MatDEM mfs.makeDisc)"),
    ("make_sphere", "make_sphere(radius, ball_r) / (…, lattice) -> Geometry", "a ball of elements centred on the origin, every element whole inside (MatDEM mfs.makeSphere)"),
    ("make_lattice", "make_lattice(\"fcc\" | \"hcp\" | \"sc\", nx, ny, nz, d) -> Geometry", "nx × ny × nz elements of diameter d on a lattice, the first at the origin; FCC and HCP stack close-packed layers along z (FCC's [111], the direction the material() formulas are derived for)"),
    ("geometry", "geometry(x, y, z, r) / geometry(table) -> Geometry", "a geometry from arrays or fields of centres (m) and radii (m; r may be one number), or from a table's x, y, z, r columns; a bad value is refused naming the element"),
    ("moved", "g.moved(dx, dy, dz) -> Geometry", "the geometry translated, m (MatDEM mfs.move)"),
    ("rotated", "g.rotated([ax, ay, az], degrees) / g.rotated(axis, degrees, [cx, cy, cz]) -> Geometry", "the geometry turned right-handedly about an axis through the origin (or through a centre) (MatDEM mfs.rotate)"),
    ("copy", "g.copy() -> Geometry", "the same geometry (geometries are values: every operation already returns a new one)"),
    ("combine", "g.combine(h) / g + h / combine([g1, g2, …]) -> Geometry", "the elements of both, g's first (MatDEM mfs.combineObj)"),
    ("filter", "g.filter(mask) -> Geometry", "the elements a mask of the geometry's length selects, e.g. g.filter(g.z < 0.05)"),
    ("bounds", "g.bounds() -> map", "the smallest box holding every element whole: #{ lo: [x, y, z], hi: [x, y, z] } (m); an empty geometry is refused"),
    ("to_table", "g.to_table() -> Table", "the elements as a table with columns x, y, z, r (save it with t.save(\"name.csv\"))"),
];

/// The documentation of every property registered here: (name, of, what it is).
pub const PROPERTIES: &[(&str, &str, &str)] = &[
    ("x", "Geometry (read)", "x of every element of a geometry, m (a Field); also y, z"),
    ("y", "Geometry (read)", "y of every element of a geometry, m"),
    ("z", "Geometry (read)", "z of every element of a geometry, m"),
    ("r", "Geometry (read)", "radius of every element of a geometry, m"),
    ("n", "Geometry (read)", "number of elements of a geometry"),
];

/// A geometry object: a shared, immutable element set.
#[derive(Debug, Clone, Default)]
pub struct Geometry(pub Rc<ElementSet>);

impl Geometry {
    fn new(s: ElementSet) -> Self {
        Geometry(Rc::new(s))
    }

    fn lane(&self, f: impl Fn(usize) -> f64) -> Field {
        Field::new((0..self.0.len()).map(f).collect())
    }

    fn describe(&self) -> String {
        match self.0.bounds() {
            None => "Geometry: 0 elements".into(),
            Some((lo, hi)) => {
                let r = self.0.radius();
                let (rmin, rmax) = r.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
                format!(
                    "Geometry: {} elements, radius {rmin:.4e}–{rmax:.4e} m, within [{:.4e}, {:.4e}] × [{:.4e}, {:.4e}] × [{:.4e}, {:.4e}] m",
                    self.0.len(),
                    lo.x,
                    hi.x,
                    lo.y,
                    hi.y,
                    lo.z,
                    hi.z
                )
            }
        }
    }
}

/// A finite number from an int or a float.
fn num(v: &Dynamic, what: &str) -> RhaiResult<f64> {
    match number(v) {
        Some(x) if x.is_finite() => Ok(x),
        Some(x) => Err(err(format!("{what} must be a finite number, got {x}"))),
        None => Err(err(format!("{what} must be a number, got {}", v.type_name()))),
    }
}

/// `[x, y, z]` of finite numbers.
fn vec3(v: &Dynamic, what: &str) -> RhaiResult<Vec3> {
    let n = to_numbers(v, what)?;
    if n.len() != 3 || !n.iter().all(|x| x.is_finite()) {
        return Err(err(format!("{what}: expected [x, y, z] with 3 finite numbers")));
    }
    Ok(Vec3::new(n[0], n[1], n[2]))
}

fn kind(s: &str) -> RhaiResult<LatticeKind> {
    s.parse().map_err(raise)
}

/// A lattice count: an integer ≥ 1.
fn count(v: &Dynamic, what: &str) -> RhaiResult<usize> {
    match v.as_int() {
        Ok(n) if n >= 1 => Ok(n as usize),
        Ok(n) => Err(err(format!("make_lattice: {what} must be an integer ≥ 1, got {n}"))),
        Err(t) => Err(err(format!("make_lattice: {what} must be an integer ≥ 1, got a {t}"))),
    }
}

/// Makes a shape, prefixing an engine refusal with the call's name.
fn shape(call: &str, s: matdem_engine::Result<ElementSet>) -> RhaiResult<Geometry> {
    s.map(Geometry::new).map_err(|e| err(format!("{call}: {e}")))
}

/// A geometry from per-element values: x, y, z (arrays or fields) and r (one, or a number).
fn from_arrays(x: &Dynamic, y: &Dynamic, z: &Dynamic, r: &Dynamic) -> RhaiResult<Geometry> {
    let (x, y, z) = (to_numbers(x, "geometry: x")?, to_numbers(y, "geometry: y")?, to_numbers(z, "geometry: z")?);
    if y.len() != x.len() || z.len() != x.len() {
        return Err(err(format!(
            "geometry: x, y and z must have the same length, got {}, {} and {}",
            x.len(),
            y.len(),
            z.len()
        )));
    }
    let r = match number(r) {
        Some(r) => vec![r; x.len()],
        None => to_numbers(r, "geometry: r")?,
    };
    let pos = (0..x.len()).map(|i| Vec3::new(x[i], y[i], z[i])).collect();
    shape("geometry", ElementSet::new(pos, r))
}

fn from_table(t: &TableData) -> RhaiResult<Geometry> {
    let col = |c: &str| {
        t.column(c)
            .map(|v| Dynamic::from(Field::new(v.to_vec())))
            .map_err(|e| err(format!("geometry: {}; give a table with columns x, y, z, r (m)", error_text(&e))))
    };
    from_arrays(&col("x")?, &col("y")?, &col("z")?, &col("r")?)
}

fn error_text(e: &rhai::EvalAltResult) -> String {
    match e {
        rhai::EvalAltResult::ErrorRuntime(v, _) => v.to_string(),
        other => other.to_string(),
    }
}

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<Geometry>("Geometry");
    // Shapes, with and without a lattice name.
    engine
        .register_fn("make_box", |w: Dynamic, l: Dynamic, h: Dynamic, r: Dynamic| make_box(&w, &l, &h, &r, "fcc"))
        .register_fn("make_box", |w: Dynamic, l: Dynamic, h: Dynamic, r: Dynamic, k: &str| make_box(&w, &l, &h, &r, k))
        .register_fn("make_column", |rad: Dynamic, h: Dynamic, r: Dynamic| make_column(&rad, &h, &r, "fcc"))
        .register_fn("make_column", |rad: Dynamic, h: Dynamic, r: Dynamic, k: &str| make_column(&rad, &h, &r, k))
        .register_fn("make_disc", |rad: Dynamic, r: Dynamic| {
            shape("make_disc", lattice::make_disc(num(&rad, "make_disc: radius")?, num(&r, "make_disc: ball_r")?))
        })
        .register_fn("make_annulus", |a: Dynamic, b: Dynamic, r: Dynamic| make_annulus(&a, &b, &r, "fcc"))
        .register_fn("make_annulus", |a: Dynamic, b: Dynamic, r: Dynamic, k: &str| make_annulus(&a, &b, &r, k))
        .register_fn("make_sphere", |rad: Dynamic, r: Dynamic| make_sphere(&rad, &r, "fcc"))
        .register_fn("make_sphere", |rad: Dynamic, r: Dynamic, k: &str| make_sphere(&rad, &r, k))
        .register_fn(
            "make_lattice",
            |k: &str, nx: Dynamic, ny: Dynamic, nz: Dynamic, d: Dynamic| -> RhaiResult<Geometry> {
                let kind = kind(k)?;
                let (nx, ny, nz) = (count(&nx, "nx")?, count(&ny, "ny")?, count(&nz, "nz")?);
                let d = num(&d, "make_lattice: d")?;
                let centres = lattice::lattice(kind, nx, ny, nz, d).map_err(|e| err(format!("make_lattice: {e}")))?;
                shape("make_lattice", ElementSet::uniform(centres, d / 2.0))
            },
        );
    for name in ["make_ring", "make_tube"] {
        engine
            .register_fn(name, move |a: Dynamic, b: Dynamic, h: Dynamic, r: Dynamic| {
                make_ring(name, &a, &b, &h, &r, "fcc")
            })
            .register_fn(name, move |a: Dynamic, b: Dynamic, h: Dynamic, r: Dynamic, k: &str| {
                make_ring(name, &a, &b, &h, &r, k)
            });
    }
    // From arrays and tables.
    engine
        .register_fn("geometry", |x: Dynamic, y: Dynamic, z: Dynamic, r: Dynamic| from_arrays(&x, &y, &z, &r))
        .register_fn("geometry", |t: Table| from_table(&t.0.borrow()));
    // Lanes.
    engine
        .register_get("x", |g: &mut Geometry| g.lane(|i| g.0.pos()[i].x))
        .register_get("y", |g: &mut Geometry| g.lane(|i| g.0.pos()[i].y))
        .register_get("z", |g: &mut Geometry| g.lane(|i| g.0.pos()[i].z))
        .register_get("r", |g: &mut Geometry| g.lane(|i| g.0.radius()[i]))
        .register_get("n", |g: &mut Geometry| g.0.len() as INT)
        .register_fn("len", |g: &mut Geometry| g.0.len() as INT);
    // Transforms: each returns a new geometry.
    engine
        .register_fn("moved", |g: &mut Geometry, dx: Dynamic, dy: Dynamic, dz: Dynamic| -> RhaiResult<Geometry> {
            let shift = Vec3::new(num(&dx, "moved: dx")?, num(&dy, "moved: dy")?, num(&dz, "moved: dz")?);
            shape("moved", g.0.translated(shift))
        })
        .register_fn("rotated", |g: &mut Geometry, axis: Dynamic, deg: Dynamic| rotated(g, &axis, &deg, None))
        .register_fn("rotated", |g: &mut Geometry, axis: Dynamic, deg: Dynamic, c: Dynamic| {
            rotated(g, &axis, &deg, Some(&c))
        })
        .register_fn("copy", |g: &mut Geometry| g.clone())
        .register_fn("combine", |g: &mut Geometry, h: Geometry| Geometry::new(g.0.combined(&h.0)))
        .register_fn("+", |g: Geometry, h: Geometry| Geometry::new(g.0.combined(&h.0)))
        .register_fn("combine", |parts: Array| -> RhaiResult<Geometry> {
            let mut out = ElementSet::default();
            for (k, p) in parts.into_iter().enumerate() {
                let t = p.type_name();
                let g = p
                    .try_cast::<Geometry>()
                    .ok_or_else(|| err(format!("combine: item {k} is a {t}, expected a Geometry")))?;
                out = out.combined(&g.0);
            }
            Ok(Geometry::new(out))
        })
        .register_fn("filter", |g: &mut Geometry, mask: Mask| -> RhaiResult<Geometry> {
            if mask.0.len() != g.0.len() {
                return Err(err(format!(
                    "filter: the mask has {} entries but the geometry has {} elements; make it from the geometry's \
                     own lanes, e.g. g.filter(g.z < 0.05)",
                    mask.0.len(),
                    g.0.len()
                )));
            }
            shape("filter", g.0.filtered(&mask.0))
        })
        .register_fn("bounds", |g: &mut Geometry| -> RhaiResult<rhai::Map> {
            let (lo, hi) = g.0.bounds().ok_or_else(|| err("bounds: the geometry has no elements"))?;
            let arr = |v: Vec3| Dynamic::from_array(v.iter().map(|c| Dynamic::from_float(*c)).collect());
            Ok(rhai::Map::from_iter([("lo".into(), arr(lo)), ("hi".into(), arr(hi))]))
        })
        .register_fn("to_table", |g: &mut Geometry| {
            let mut t = TableData::default();
            for (p, r) in g.0.pos().iter().zip(g.0.radius()) {
                t.push(&[("x".into(), p.x), ("y".into(), p.y), ("z".into(), p.z), ("r".into(), *r)]);
            }
            Table(Rc::new(std::cell::RefCell::new(t)))
        })
        .register_fn("to_string", |g: &mut Geometry| g.describe())
        .register_fn("to_debug", |g: &mut Geometry| g.describe());
}

fn make_box(w: &Dynamic, l: &Dynamic, h: &Dynamic, r: &Dynamic, k: &str) -> RhaiResult<Geometry> {
    let (w, l, h) = (num(w, "make_box: w")?, num(l, "make_box: l")?, num(h, "make_box: h")?);
    shape("make_box", lattice::make_box(w, l, h, num(r, "make_box: ball_r")?, kind(k)?))
}

fn make_column(rad: &Dynamic, h: &Dynamic, r: &Dynamic, k: &str) -> RhaiResult<Geometry> {
    let (rad, h) = (num(rad, "make_column: radius")?, num(h, "make_column: h")?);
    shape("make_column", lattice::make_column(rad, h, num(r, "make_column: ball_r")?, kind(k)?))
}

fn make_ring(call: &str, a: &Dynamic, b: &Dynamic, h: &Dynamic, r: &Dynamic, k: &str) -> RhaiResult<Geometry> {
    let (a, b) = (num(a, &format!("{call}: r_in"))?, num(b, &format!("{call}: r_out"))?);
    let (h, r) = (num(h, &format!("{call}: h"))?, num(r, &format!("{call}: ball_r"))?);
    shape(call, lattice::make_ring(a, b, h, r, kind(k)?))
}

fn make_annulus(a: &Dynamic, b: &Dynamic, r: &Dynamic, k: &str) -> RhaiResult<Geometry> {
    let (a, b) = (num(a, "make_annulus: r_in")?, num(b, "make_annulus: r_out")?);
    shape("make_annulus", lattice::make_annulus_2d(a, b, num(r, "make_annulus: ball_r")?, kind(k)?))
}

fn make_sphere(rad: &Dynamic, r: &Dynamic, k: &str) -> RhaiResult<Geometry> {
    let rad = num(rad, "make_sphere: radius")?;
    shape("make_sphere", lattice::make_sphere(rad, num(r, "make_sphere: ball_r")?, kind(k)?))
}

fn rotated(g: &Geometry, axis: &Dynamic, deg: &Dynamic, centre: Option<&Dynamic>) -> RhaiResult<Geometry> {
    let axis = vec3(axis, "rotated: axis")?;
    let angle = num(deg, "rotated: degrees")?.to_radians();
    let centre = centre.map(|c| vec3(c, "rotated: centre")).transpose()?.unwrap_or_else(Vec3::zeros);
    shape("rotated", g.0.rotated(centre, axis, angle))
}
