//! Cutting and layers (MatDEM's `Tool_Cut`, the rest of step 2): surfaces through scattered
//! points (`cut_surface`), cuts that delete what lies above or below one (`d.cut_above`,
//! `d.cut_below`), masks above or below, layers between surfaces as groups
//! `layer1…layerN` (`d.layers_between` with surfaces), prisms over a polygon in plan
//! (`d.in_polygon`), and joints: bonds across a surface or plane broken or set to a share
//! of their strength (`d.set_joint`, MatDEM's `setSurfBond`).
//!
//! As in regions.rs, what reads positions is observed (journaled: a resumed run gets the
//! same masks back) and what changes the model is an action done with the observed masks,
//! so a replay cuts and weakens the same elements. Every input is checked before the model
//! changes.

use super::elements::finite;
use super::*;
use matdem_engine::geometry::{Polygon, Surface};
use matdem_engine::model::Breakage;
use matdem_engine::physics::contact_law::BreakKind;

/// The documentation of every name registered here: (name, usage, what it does).
pub const DOCS: &[(&str, &str, &str)] = &[
    ("cut_surface", "cut_surface(points) / cut_surface(table) / cut_surface(x, y, z) -> CutSurface", "a surface z = h(x, y) through scattered points ([[x, y, z], …], a table with columns x, y, z, or three arrays or fields), triangulated in plan (Delaunay) and linear in each triangle; outside the points' hull it keeps the height of the hull's nearest point (MatDEM Tool_Cut.addSurf)"),
    ("height", "s.height(x, y) -> f64 or Field", "a cut surface's height at plan positions (numbers, or fields of the same length), m"),
    ("above_surface", "d.above_surface(s) -> Mask", "the elements whose centre lies strictly above a cut surface"),
    ("below_surface", "d.below_surface(s) -> Mask", "the elements whose centre lies strictly below a cut surface (centres exactly on it are in neither mask)"),
    ("cut_above", "d.cut_above(s) -> count", "deletes the elements whose centre lies above a cut surface (a terrain's air); returns how many went"),
    ("cut_below", "d.cut_below(s) -> count", "deletes the elements whose centre lies below a cut surface; returns how many went"),
    ("in_polygon", "d.in_polygon([[x, y], …]) / d.in_polygon([[x, y], …], z0, z1) -> Mask", "the elements whose centre lies inside a polygon in plan (even–odd rule), optionally between heights z0 ≤ z ≤ z1: a prism region"),
    ("set_joint", "d.set_joint(s, share) / d.set_joint([x, y, z], [nx, ny, nz], share) -> count", "a joint: every bond whose two elements lie on opposite sides of a cut surface (or a plane through a point) keeps `share` (0 … 1) of its strength, breaking force and Fs0; 0 breaks them; returns how many bonds (MatDEM setSurfBond)"),
    ("breakages", "d.breakages() -> map", "every bond broken so far, in order: #{ step, time, i, j, kind } as fields (kind 1 tension, 2 shear); ids as they were when the bond broke"),
];

/// A cut surface: shared, immutable.
#[derive(Debug, Clone)]
pub struct CutSurface(pub Rc<Surface>);

/// `[x, y, z]` points from an array of 3-arrays.
fn points_of(a: &Array) -> RhaiResult<Vec<Vec3>> {
    a.iter().enumerate().map(|(k, p)| vec3(p, &format!("cut_surface: point {k}"))).collect()
}

fn make(points: Vec<Vec3>) -> RhaiResult<CutSurface> {
    Surface::from_points(&points).map(|s| CutSurface(Rc::new(s))).map_err(|e| err(format!("cut_surface: {e}")))
}

fn from_columns(x: &Dynamic, y: &Dynamic, z: &Dynamic) -> RhaiResult<CutSurface> {
    let (x, y, z) =
        (to_numbers(x, "cut_surface: x")?, to_numbers(y, "cut_surface: y")?, to_numbers(z, "cut_surface: z")?);
    if y.len() != x.len() || z.len() != x.len() {
        return Err(err(format!(
            "cut_surface: x, y and z must have the same length, got {}, {} and {}",
            x.len(),
            y.len(),
            z.len()
        )));
    }
    make((0..x.len()).map(|k| Vec3::new(x[k], y[k], z[k])).collect())
}

/// A layer boundary: a number is a horizontal plane, a cut surface its height field.
enum Boundary {
    Flat(f64),
    Surface(Rc<Surface>),
}

impl Boundary {
    fn height(&self, p: &Vec3) -> f64 {
        match self {
            Boundary::Flat(z) => *z,
            Boundary::Surface(s) => s.height(p.x, p.y),
        }
    }
}

/// Whether an array holds a cut surface (then `layers_between` reads it as boundaries).
pub(super) fn has_surfaces(a: &Array) -> bool {
    a.iter().any(|v| v.is::<CutSurface>())
}

/// Groups `layer1…layerN` between boundaries given bottom first: layer k holds the centres
/// with h(k−1) ≤ z < h(k) at their own (x, y), the last including its top. Where two
/// surfaces cross, the layer between them is empty there. Returns the counts.
pub(super) fn layers_between_surfaces(host: &Host, d: &ModelHandle, items: &Array) -> RhaiResult<Array> {
    let bounds = items
        .iter()
        .enumerate()
        .map(|(k, v)| match v.clone().try_cast::<CutSurface>() {
            Some(s) => Ok(Boundary::Surface(s.0)),
            None => finite(v, &format!("layers_between: boundary {k} (a cut surface or a height)")).map(Boundary::Flat),
        })
        .collect::<RhaiResult<Vec<_>>>()?;
    if bounds.len() < 2 {
        return Err(err(format!(
            "layers_between: give at least two boundaries (the bottom and top of one layer), got {}",
            bounds.len()
        )));
    }
    let last = bounds.len() - 2;
    let masks = host.observe("layers_between", || {
        let m = d.model();
        let layer = |k: usize| {
            let inside = m.particles.pos.iter().map(|p| {
                let (lo, hi) = (bounds[k].height(p), bounds[k + 1].height(p));
                lo <= p.z && (p.z < hi || (k == last && p.z == hi))
            });
            Dynamic::from(Mask::new(inside.collect()))
        };
        Ok(Dynamic::from_array((0..=last).map(layer).collect()))
    })?;
    let masks = masks.try_cast::<Array>().ok_or_else(|| err("internal error: layers_between masks"))?;
    let mut m = d.model();
    let mut counts = Array::new();
    for (k, mask) in masks.into_iter().enumerate() {
        let ids = resolve_ids(&m, &mask)?;
        counts.push((ids.len() as INT).into());
        m.groups.set(&format!("layer{}", k + 1), ids);
    }
    Ok(counts)
}

/// The mask of the elements whose centre satisfies `inside`.
fn mask_where(d: &ModelHandle, inside: impl Fn(&Vec3) -> bool) -> Mask {
    let m = d.model();
    Mask::new(m.particles.pos.iter().map(inside).collect())
}

/// Deletes the elements of an observed mask; returns how many went.
fn cut(host: &Host, d: &ModelHandle, call: &str, inside: impl Fn(&Vec3) -> bool) -> RhaiResult<INT> {
    let mask = host.observe(call, || Ok(Dynamic::from(mask_where(d, inside))))?;
    let mut m = d.model();
    let ids = resolve_ids(&m, &mask)?;
    m.remove_particles(&ids).map_err(raise)?;
    Ok(ids.len() as INT)
}

/// Sets the bonds between elements on opposite sides (by an observed side mask) to `share`.
fn joint(host: &Host, d: &ModelHandle, share: &Dynamic, side: impl Fn(&Vec3) -> bool) -> RhaiResult<INT> {
    let share = finite(share, "set_joint: share")?;
    if !(0.0..=1.0).contains(&share) {
        return Err(err(format!(
            "set_joint: share = {share}; give the share of strength the joint keeps, from 0 (break) to 1 (whole)"
        )));
    }
    let mask = host.observe("set_joint", || Ok(Dynamic::from(mask_where(d, side))))?;
    let mask = mask.try_cast::<Mask>().ok_or_else(|| err("internal error: set_joint mask"))?;
    let mut m = d.model();
    if mask.0.len() != m.len() {
        return Err(err("internal error: set_joint mask length"));
    }
    let n = m.set_bond_strength(|i, j| mask.0[i] != mask.0[j], share).map_err(raise)?;
    Ok(n as INT)
}

fn polygon(vertices: &Array) -> RhaiResult<Polygon> {
    let xy = vertices
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let n = to_numbers(v, &format!("in_polygon: vertex {k}"))?;
            match n[..] {
                [x, y] => Ok((x, y)),
                _ => Err(err(format!("in_polygon: vertex {k} has {} numbers; give [x, y]", n.len()))),
            }
        })
        .collect::<RhaiResult<Vec<_>>>()?;
    Polygon::new(xy).map_err(|e| err(format!("in_polygon: {e}")))
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine.register_type_with_name::<CutSurface>("CutSurface");
    engine
        .register_fn("cut_surface", |points: Array| make(points_of(&points)?))
        .register_fn("cut_surface", |t: Table| {
            let data = t.0.borrow();
            let col = |c: &str| {
                data.column(c).map(|v| Dynamic::from(Field::new(v.to_vec()))).map_err(|e| {
                    let msg = match *e {
                        EvalAltResult::ErrorRuntime(ref v, _) => v.to_string(),
                        ref other => other.to_string(),
                    };
                    err(format!("cut_surface: {msg}; give a table with columns x, y, z (m)"))
                })
            };
            from_columns(&col("x")?, &col("y")?, &col("z")?)
        })
        .register_fn("cut_surface", |x: Dynamic, y: Dynamic, z: Dynamic| from_columns(&x, &y, &z))
        .register_fn("height", |s: &mut CutSurface, x: Dynamic, y: Dynamic| -> RhaiResult<Dynamic> {
            if let (Some(x), Some(y)) = (number(&x), number(&y)) {
                if !(x.is_finite() && y.is_finite()) {
                    return Err(err(format!("height: ({x}, {y}) is not a finite position")));
                }
                return Ok(Dynamic::from_float(s.0.height(x, y)));
            }
            let (x, y) = (to_numbers(&x, "height: x")?, to_numbers(&y, "height: y")?);
            if x.len() != y.len() {
                return Err(err(format!("height: x and y must have the same length, got {} and {}", x.len(), y.len())));
            }
            Ok(Dynamic::from(Field::new(x.iter().zip(&y).map(|(x, y)| s.0.height(*x, *y)).collect())))
        })
        .register_fn("to_string", |s: &mut CutSurface| format!("CutSurface: through {} points", s.0.points()))
        .register_fn("to_debug", |s: &mut CutSurface| format!("CutSurface: through {} points", s.0.points()));
    let h = host.clone();
    engine.register_fn("above_surface", move |d: &mut ModelHandle, s: CutSurface| {
        h.observe("above_surface", || Ok(Dynamic::from(mask_where(d, |p| s.0.is_above(p)))))
    });
    let h = host.clone();
    engine.register_fn("below_surface", move |d: &mut ModelHandle, s: CutSurface| {
        h.observe("below_surface", || Ok(Dynamic::from(mask_where(d, |p| p.z < s.0.height(p.x, p.y)))))
    });
    let h = host.clone();
    engine.register_fn("cut_above", move |d: &mut ModelHandle, s: CutSurface| {
        cut(&h, d, "cut_above", |p| s.0.is_above(p))
    });
    let h = host.clone();
    engine.register_fn("cut_below", move |d: &mut ModelHandle, s: CutSurface| {
        cut(&h, d, "cut_below", |p| p.z < s.0.height(p.x, p.y))
    });
    let h = host.clone();
    engine.register_fn("in_polygon", move |d: &mut ModelHandle, vertices: Array| -> RhaiResult<Dynamic> {
        let poly = polygon(&vertices)?;
        h.observe("in_polygon", || Ok(Dynamic::from(mask_where(d, |p| poly.contains(p.x, p.y)))))
    });
    let h = host.clone();
    engine.register_fn(
        "in_polygon",
        move |d: &mut ModelHandle, vertices: Array, z0: Dynamic, z1: Dynamic| -> RhaiResult<Dynamic> {
            let poly = polygon(&vertices)?;
            let (z0, z1) = (finite(&z0, "in_polygon: z0")?, finite(&z1, "in_polygon: z1")?);
            if z0 > z1 {
                return Err(err(format!("in_polygon: z0 = {z0} is above z1 = {z1}; give the lower height first")));
            }
            h.observe("in_polygon", || Ok(Dynamic::from(mask_where(d, |p| poly.prism_contains(p, z0, z1)))))
        },
    );
    let h = host.clone();
    engine.register_fn("set_joint", move |d: &mut ModelHandle, s: CutSurface, share: Dynamic| {
        joint(&h, d, &share, |p| s.0.is_above(p))
    });
    let h = host.clone();
    engine.register_fn("set_joint", move |d: &mut ModelHandle, point: Array, normal: Array, share: Dynamic| {
        let point = vec3(&Dynamic::from_array(point), "set_joint: point")?;
        let n = vec3(&Dynamic::from_array(normal), "set_joint: normal")?;
        if n.norm() == 0.0 {
            return Err(err("set_joint: the normal must not be [0, 0, 0]"));
        }
        joint(&h, d, &share, |p| (p - point).dot(&n) > 0.0)
    });
    let h = host.clone();
    engine.register_fn("breakages", move |d: &mut ModelHandle| {
        h.observe("breakages", || {
            let m = d.model();
            let lane = |f: fn(&Breakage) -> f64| Dynamic::from(Field::new(m.breakages.iter().map(f).collect()));
            Ok(Dynamic::from_map(Map::from_iter([
                ("step".into(), lane(|k| k.step as f64)),
                ("time".into(), lane(|k| k.time)),
                ("i".into(), lane(|k| f64::from(k.i))),
                ("j".into(), lane(|k| f64::from(k.j))),
                ("kind".into(), lane(|k| if k.kind == BreakKind::Tension { 1.0 } else { 2.0 })),
            ])))
        })
    });
}
