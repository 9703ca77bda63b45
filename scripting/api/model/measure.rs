//! Measurement regions (`d.measure(region)`): a sphere, a box or a vertical cylinder given as a
//! map; in it the mean stress by Love–Weber, the porosity and the coordination number, and,
//! against a reference state, the strain from the best-fit displacement gradient
//! (`matdem_engine::analysis::measure`, docs/analysis.md for the rules).

use super::*;
use matdem_engine::analysis::{measure, strain};
use nalgebra::Matrix3;

/// The documentation of every name registered here: (name, usage, what it does).
pub const DOCS: &[(&str, &str, &str)] = &[
    ("measure", "d.measure(region) / d.measure(region, reference) -> map", "a measurement region: #{ center: [x, y, z], radius } (a sphere), #{ lo: [x, y, z], hi: [x, y, z] } (a box) or #{ center: [x, y], radius, z0, z1 } (a vertical cylinder). Returns #{ stress (3×3, Pa, compression > 0, Love–Weber: σ = −(1/V)·Σ w·f ⊗ l over the contacts, each cut contact counted by the share w of its branch vector inside; in a periodic cell the parts of branches and spheres that reach the region through the faces count too, so the whole cell gives the cell's stress and porosity), stress_xx … stress_yz, mean_stress, deviator_stress, principal_stress, principal_directions, porosity (exact volumes), coordination (contacts per element whose centre is inside), elements, volume }; with a reference state (a model loaded with load_model, or #{ x, y, z } Fields of the same elements, e.g. #{ x: d.x, y: d.y, z: d.z } kept earlier) it adds the strain of the region's elements from the best-fit deformation gradient F: strain (Green–Lagrange, compression > 0), strain_xx … strain_yz, volumetric_strain, deviatoric_strain (3×3), deviatoric_equivalent, volume_change (det F − 1), deformation_gradient, fit_residual (m)"),
];

/// A region from a script's map (see [`DOCS`]).
pub(crate) fn region(v: &Dynamic, call: &str) -> RhaiResult<Region> {
    let usage = "give #{ center: [x, y, z], radius } (a sphere), #{ lo: [x, y, z], hi: [x, y, z] } (a box) or \
                 #{ center: [x, y], radius, z0, z1 } (a vertical cylinder)";
    let map = v.clone().try_cast::<Map>().ok_or_else(|| err(format!("{call}: the region is a map: {usage}")))?;
    for key in map.keys() {
        if !["center", "radius", "lo", "hi", "z0", "z1"].contains(&key.as_str()) {
            return Err(err(format!("{call}: unknown region key `{key}`; {usage}")));
        }
    }
    let num = |k: &str| -> RhaiResult<f64> {
        let v = map.get(k).ok_or_else(|| err(format!("{call}: the region needs `{k}`; {usage}")))?;
        let x = number(v).ok_or_else(|| err(format!("{call}: `{k}` must be a number, got {}", v.type_name())))?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(err(format!("{call}: `{k}` is {x}; give a finite number (m)")))
        }
    };
    let point = |k: &str, n: usize| -> RhaiResult<Vec<f64>> {
        let v = map.get(k).ok_or_else(|| err(format!("{call}: the region needs `{k}`; {usage}")))?;
        let p = to_numbers(v, &format!("{call}: {k}"))?;
        if p.len() != n || !p.iter().all(|x| x.is_finite()) {
            return Err(err(format!("{call}: `{k}` must be {n} finite numbers (m), got {p:?}")));
        }
        Ok(p)
    };
    if map.contains_key("lo") || map.contains_key("hi") {
        let (lo, hi) = (point("lo", 3)?, point("hi", 3)?);
        if let Some(k) = (0..3).find(|&k| lo[k] >= hi[k]) {
            let axis = ["x", "y", "z"][k];
            return Err(err(format!(
                "{call}: the box is empty or inverted along {axis} (lo {} ≥ hi {}); give the lower corner as lo",
                lo[k], hi[k]
            )));
        }
        return Ok(Region::Box { lo: Vec3::new(lo[0], lo[1], lo[2]), hi: Vec3::new(hi[0], hi[1], hi[2]) });
    }
    let radius = num("radius")?;
    if radius <= 0.0 {
        return Err(err(format!("{call}: the radius must be > 0 m, got {radius}")));
    }
    if map.contains_key("z0") || map.contains_key("z1") {
        let c = point("center", 2)?;
        let (z0, z1) = (num("z0")?, num("z1")?);
        if z0 >= z1 {
            return Err(err(format!("{call}: z0 = {z0} is not below z1 = {z1}; give z0 < z1")));
        }
        return Ok(Region::Cylinder { center: Vec3::new(c[0], c[1], 0.0), radius, z0, z1 });
    }
    let c = point("center", 3)?;
    Ok(Region::Sphere { center: Vec3::new(c[0], c[1], c[2]), radius })
}

/// A 3×3 tensor as an array of rows.
pub(crate) fn tensor(t: &Matrix3<f64>) -> Array {
    (0..3).map(|i| Dynamic::from_array((0..3).map(|j| Dynamic::from_float(t[(i, j)])).collect())).collect()
}

pub(crate) fn vector(v: &Vec3) -> Array {
    (0..3).map(|k| Dynamic::from_float(v[k])).collect()
}

/// Inserts a tensor's six components as `{prefix}_xx` … `{prefix}_yz`.
fn components(map: &mut Map, prefix: &str, t: &Matrix3<f64>) {
    for (name, (i, j)) in
        [("xx", (0, 0)), ("yy", (1, 1)), ("zz", (2, 2)), ("xy", (0, 1)), ("xz", (0, 2)), ("yz", (1, 2))]
    {
        map.insert(format!("{prefix}_{name}").into(), Dynamic::from_float(t[(i, j)]));
    }
}

/// The reference positions a script gave: a model of the same elements, or #{ x, y, z }.
fn reference_positions(v: &Dynamic, n: usize) -> RhaiResult<Vec<Vec3>> {
    if let Some(h) = v.clone().try_cast::<ModelHandle>() {
        return Ok(h.data().sim.model.particles.pos.clone());
    }
    let map = v.clone().try_cast::<Map>().ok_or_else(|| {
        err(format!(
            "measure: the reference is a model (load_model) or #{{ x, y, z }} of Fields, got {}",
            v.type_name()
        ))
    })?;
    let lane = |k: &str| -> RhaiResult<Vec<f64>> {
        let f =
            map.get(k).ok_or_else(|| err(format!("measure: the reference map needs `{k}` (a Field, e.g. d.{k})")))?;
        let values = to_numbers(f, &format!("measure: reference {k}"))?;
        if values.len() != n {
            return Err(err(format!(
                "measure: the reference's {k} has {} values but the model has {n} elements; keep it from the same \
                 model (before elements were added or deleted)",
                values.len()
            )));
        }
        Ok(values)
    };
    let (x, y, z) = (lane("x")?, lane("y")?, lane("z")?);
    Ok((0..n).map(|i| Vec3::new(x[i], y[i], z[i])).collect())
}

fn measured(d: &ModelHandle, region: &Region, reference: Option<&[Vec3]>) -> RhaiResult<Map> {
    let list = super::contacts::contact_list(d);
    let m = d.model();
    let r = measure(&m, &list, region).map_err(raise)?;
    let mut map = Map::new();
    map.insert("stress".into(), Dynamic::from_array(tensor(&r.stress)));
    components(&mut map, "stress", &r.stress);
    for (k, v) in [
        ("mean_stress", r.mean_stress),
        ("deviator_stress", r.deviator_stress),
        ("porosity", r.porosity),
        ("coordination", r.coordination),
        ("volume", r.volume),
    ] {
        map.insert(k.into(), Dynamic::from_float(v));
    }
    map.insert("elements".into(), Dynamic::from_int(r.elements as INT));
    map.insert(
        "principal_stress".into(),
        Dynamic::from_array(r.principal_stress.iter().map(|v| Dynamic::from_float(*v)).collect()),
    );
    map.insert(
        "principal_directions".into(),
        Dynamic::from_array(r.principal_directions.iter().map(|v| Dynamic::from_array(vector(v))).collect()),
    );
    if let Some(reference) = reference {
        let p = &m.particles;
        let inside: Vec<bool> = (0..p.len()).map(|i| !m.is_killed(i) && region.contains(&p.pos[i])).collect();
        let s = strain(reference, &p.pos, &inside).map_err(raise)?;
        map.insert("strain".into(), Dynamic::from_array(tensor(&s.strain)));
        components(&mut map, "strain", &s.strain);
        map.insert("volumetric_strain".into(), Dynamic::from_float(s.volumetric));
        map.insert("deviatoric_strain".into(), Dynamic::from_array(tensor(&s.deviatoric)));
        map.insert("deviatoric_equivalent".into(), Dynamic::from_float(s.deviatoric_equivalent));
        map.insert("volume_change".into(), Dynamic::from_float(s.volume_change));
        map.insert("deformation_gradient".into(), Dynamic::from_array(tensor(&s.deformation_gradient)));
        map.insert("fit_residual".into(), Dynamic::from_float(s.residual));
    }
    Ok(map)
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    let h = host.clone();
    engine.register_fn("measure", move |d: &mut ModelHandle, r: Dynamic| -> RhaiResult<Dynamic> {
        let region = region(&r, "measure")?;
        h.observe("measure", || measured(d, &region, None).map(Dynamic::from_map))
    });
    let h = host.clone();
    engine.register_fn("measure", move |d: &mut ModelHandle, r: Dynamic, reference: Dynamic| -> RhaiResult<Dynamic> {
        let region = region(&r, "measure")?;
        let n = d.model().len();
        let reference = reference_positions(&reference, n)?;
        h.observe("measure", || measured(d, &region, Some(&reference)).map(Dynamic::from_map))
    });
}
