//! Regions and layers (the simple part of MatDEM's `Tool_Cut`): masks of the elements whose
//! centres lie in a box, a sphere, a vertical cylinder or above a plane, which combine with
//! `& | !` and feed `add_group`, `delete` and `set`; and layers between parallel planes as
//! groups `layer1…layerN`.
//!
//! A region reads positions, so it is an observation (journaled: a resumed run gets the
//! same mask back). `layers_between` observes its masks the same way, then sets the groups
//! as an action, so a replay names the same elements.

use super::elements::finite;
use super::*;

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    let h = host.clone();
    engine.register_fn(
        "in_box",
        move |d: &mut ModelHandle,
              x0: Dynamic,
              x1: Dynamic,
              y0: Dynamic,
              y1: Dynamic,
              z0: Dynamic,
              z1: Dynamic|
              -> RhaiResult<Dynamic> {
            let lo = Vec3::new(finite(&x0, "in_box: x0")?, finite(&y0, "in_box: y0")?, finite(&z0, "in_box: z0")?);
            let hi = Vec3::new(finite(&x1, "in_box: x1")?, finite(&y1, "in_box: y1")?, finite(&z1, "in_box: z1")?);
            if let Some(k) = (0..3).find(|&k| lo[k] > hi[k]) {
                let axis = ["x", "y", "z"][k];
                return Err(err(format!(
                    "in_box: the box is inverted along {axis} ({axis}0 = {} > {axis}1 = {}); give \
                     in_box(x0, x1, y0, y1, z0, z1) with each lower bound first",
                    lo[k], hi[k]
                )));
            }
            h.observe("in_box", || Ok(Dynamic::from(mask_where(d, |p| (0..3).all(|k| lo[k] <= p[k] && p[k] <= hi[k])))))
        },
    );
    let h = host.clone();
    engine.register_fn(
        "in_sphere",
        move |d: &mut ModelHandle, cx: Dynamic, cy: Dynamic, cz: Dynamic, r: Dynamic| -> RhaiResult<Dynamic> {
            let c =
                Vec3::new(finite(&cx, "in_sphere: cx")?, finite(&cy, "in_sphere: cy")?, finite(&cz, "in_sphere: cz")?);
            let r = positive("in_sphere: the radius", finite(&r, "in_sphere: r")?)?;
            h.observe("in_sphere", || Ok(Dynamic::from(mask_where(d, |p| (p - c).norm_squared() <= r * r))))
        },
    );
    let h = host.clone();
    engine.register_fn(
        "in_cylinder",
        move |d: &mut ModelHandle, cx: Dynamic, cy: Dynamic, r: Dynamic, z0: Dynamic, z1: Dynamic| {
            let (cx, cy) = (finite(&cx, "in_cylinder: cx")?, finite(&cy, "in_cylinder: cy")?);
            let r = positive("in_cylinder: the radius", finite(&r, "in_cylinder: r")?)?;
            let (z0, z1) = (finite(&z0, "in_cylinder: z0")?, finite(&z1, "in_cylinder: z1")?);
            if z0 > z1 {
                return Err(err(format!(
                    "in_cylinder: z0 = {z0} is above z1 = {z1}; give in_cylinder(cx, cy, r, z0, z1) with z0 ≤ z1"
                )));
            }
            h.observe("in_cylinder", || {
                Ok(Dynamic::from(mask_where(d, |p| {
                    let (dx, dy) = (p.x - cx, p.y - cy);
                    dx * dx + dy * dy <= r * r && z0 <= p.z && p.z <= z1
                })))
            })
        },
    );
    let h = host.clone();
    engine.register_fn("above_plane", move |d: &mut ModelHandle, point: Array, normal: Array| {
        let point = vec3(&Dynamic::from_array(point), "above_plane: point")?;
        let n = unit(vec3(&Dynamic::from_array(normal), "above_plane: normal")?, "above_plane")?;
        h.observe("above_plane", || Ok(Dynamic::from(mask_where(d, |p| (p - point).dot(&n) > 0.0))))
    });
    let h = host.clone();
    engine.register_fn("layers_between", move |d: &mut ModelHandle, zs: Array| {
        if super::cutting::has_surfaces(&zs) {
            return super::cutting::layers_between_surfaces(&h, d, &zs);
        }
        let points = zs
            .iter()
            .enumerate()
            .map(|(k, z)| Ok(Vec3::new(0.0, 0.0, finite(z, &format!("layers_between: height {k}"))?)))
            .collect::<RhaiResult<Vec<_>>>()?;
        layers(&h, d, &points, Vec3::z())
    });
    let h = host.clone();
    engine.register_fn("layers_between", move |d: &mut ModelHandle, points: Array, normal: Array| {
        let points = points
            .into_iter()
            .enumerate()
            .map(|(k, p)| vec3(&p, &format!("layers_between: point {k}")))
            .collect::<RhaiResult<Vec<_>>>()?;
        let n = unit(vec3(&Dynamic::from_array(normal), "layers_between: normal")?, "layers_between")?;
        layers(&h, d, &points, n)
    });
}

/// The mask of the particles whose centre satisfies `inside`.
fn mask_where(d: &ModelHandle, inside: impl Fn(&Vec3) -> bool) -> Mask {
    let m = d.model();
    Mask::new(m.particles.pos.iter().map(inside).collect())
}

fn unit(n: Vec3, call: &str) -> RhaiResult<Vec3> {
    let len = n.norm();
    if !(len > 0.0 && len.is_finite()) {
        return Err(err(format!("{call}: the normal must not be [0, 0, 0]")));
    }
    Ok(n / len)
}

/// Groups `layer1…layerN` between N + 1 parallel planes through `points` with normal `n`,
/// given in order along `n`: layer k holds the centres with s_{k−1} ≤ s < s_k (the last
/// layer includes its upper plane), where s is the distance along `n`. Returns the counts.
fn layers(host: &Host, d: &ModelHandle, points: &[Vec3], n: Vec3) -> RhaiResult<Array> {
    let s: Vec<f64> = points.iter().map(|p| p.dot(&n)).collect();
    if s.len() < 2 {
        return Err(err(format!(
            "layers_between: give at least two planes (the bottom and top of one layer), got {}",
            s.len()
        )));
    }
    if let Some(k) = (1..s.len()).find(|&k| s[k] <= s[k - 1]) {
        return Err(err(format!(
            "layers_between: plane {k} (at {}) is not beyond plane {} (at {}) along the normal; give the planes \
             in increasing order, bottom first",
            s[k],
            k - 1,
            s[k - 1]
        )));
    }
    let masks = host.observe("layers_between", || {
        let m = d.model();
        let last = s.len() - 2;
        let layer = |k: usize| -> Dynamic {
            let inside = m.particles.pos.iter().map(|p| {
                let t = p.dot(&n);
                s[k] <= t && (t < s[k + 1] || (k == last && t == s[k + 1]))
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
