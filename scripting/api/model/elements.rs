//! Elements in and out (MatDEM's step 2, "cut and assign"): delete (`delElement`), kill during
//! a run keeping every id (`killElement`, engine/src/kill.rs), add from
//! a table (`addElement`), keep only some groups (`makeModelByGroups`), move or turn a group
//! (`moveGroup`, `rotateGroup`), freeze a group into a wall (`defineWallElement`).
//!
//! These are actions: a resumed run repeats them while it replays, so the model keeps the
//! shape (particle count, groups) the journaled observations were made on. Each checks its
//! whole input before it changes anything.

use super::*;
use crate::api::geometry::Geometry;
use matdem_engine::geometry::ElementSet;
use matdem_engine::state::particles::dof;

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    let h = host.clone();
    // An empty model to build from geometry objects (MatDEM builds d from mfs objects).
    engine.register_fn("new_model", move |name: &str| h.adopt(name, Model::new()));
    engine
        .register_fn("delete", |d: &mut ModelHandle, sel: Dynamic| -> RhaiResult<INT> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            m.remove_particles(&ids).map_err(raise)?;
            Ok(ids.len() as INT)
        })
        .register_fn("kill", |d: &mut ModelHandle, sel: Dynamic| -> RhaiResult<Map> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            let r = m.kill(&ids).map_err(raise)?;
            let mut out = Map::new();
            out.insert("killed".into(), (r.killed as INT).into());
            out.insert("bonds_broken".into(), (r.bonds_broken as INT).into());
            out.insert("energy".into(), r.energy.into());
            Ok(out)
        })
        .register_get("killed", |d: &mut ModelHandle| {
            let m = d.model();
            Mask::new((0..m.len()).map(|i| m.is_killed(i)).collect())
        })
        .register_fn("keep_groups", |d: &mut ModelHandle, names: Array| -> RhaiResult<INT> {
            let mut m = d.model();
            if names.is_empty() {
                return Err(err("keep_groups: name at least one group to keep (d.delete(\"all\") empties the model)"));
            }
            let mut keep = vec![false; m.len()];
            for name in &names {
                let name = name
                    .clone()
                    .into_string()
                    .map_err(|t| err(format!("keep_groups: expected an array of group names, got a {t} in it")))?;
                for &i in m.groups.get(&name).map_err(raise)? {
                    keep[i as usize] = true;
                }
            }
            let doomed: Vec<u32> = (0..m.len() as u32).filter(|&i| !keep[i as usize]).collect();
            m.remove_particles(&doomed).map_err(raise)?;
            Ok(doomed.len() as INT)
        })
        .register_fn("add_elements", |d: &mut ModelHandle, t: Table, mat: Dynamic, group: &str| {
            add_elements(&mut d.model(), &t, &mat, group)
        })
        .register_fn("add_elements", |d: &mut ModelHandle, g: Geometry, mat: Dynamic, group: &str| {
            // A geometry's values were checked when it was made.
            add_checked(&mut d.model(), g.0.pos(), g.0.radius(), &mat, group)
        })
        .register_fn(
            "move_group",
            |d: &mut ModelHandle, sel: Dynamic, dx: Dynamic, dy: Dynamic, dz: Dynamic| -> RhaiResult<()> {
                let shift = Vec3::new(
                    finite(&dx, "move_group: dx")?,
                    finite(&dy, "move_group: dy")?,
                    finite(&dz, "move_group: dz")?,
                );
                let mut m = d.model();
                let ids = resolve_ids(&m, &sel)?;
                for &i in &ids {
                    m.particles.pos[i as usize] += shift;
                }
                m.positions_changed();
                Ok(())
            },
        )
        .register_fn(
            "rotate_group",
            |d: &mut ModelHandle, sel: Dynamic, axis: Dynamic, deg: Dynamic, about: Dynamic| -> RhaiResult<INT> {
                let axis = vec3(&axis, "rotate_group: axis")?;
                let angle = finite(&deg, "rotate_group: angle (degrees)")?.to_radians();
                let centre = vec3(&about, "rotate_group: about_point")?;
                let mut m = d.model();
                let ids = resolve_ids(&m, &sel)?;
                // The engine's rigid rotation (the one geometry objects use) checks the axis.
                let pos: Vec<Vec3> = ids.iter().map(|&i| m.particles.pos[i as usize]).collect();
                let radius: Vec<f64> = ids.iter().map(|&i| m.particles.radius[i as usize]).collect();
                let turned = ElementSet::new(pos, radius)
                    .and_then(|s| s.rotated(centre, axis, angle))
                    .map_err(|e| err(format!("rotate_group: {e}")))?;
                for (&i, p) in ids.iter().zip(turned.pos()) {
                    m.particles.pos[i as usize] = *p;
                }
                m.positions_changed();
                Ok(ids.len() as INT)
            },
        )
        .register_fn("freeze", |d: &mut ModelHandle, sel: Dynamic| -> RhaiResult<INT> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            m.fix(&ids, dof::ALL, true).map_err(raise)?;
            let p = &mut m.particles;
            for &i in &ids {
                p.vel[i as usize] = Vec3::zeros();
                if let Some(rot) = &mut p.rotation {
                    rot.ang_vel[i as usize] = Vec3::zeros();
                }
            }
            Ok(ids.len() as INT)
        })
        .register_fn("unfreeze", |d: &mut ModelHandle, sel: Dynamic| -> RhaiResult<INT> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            m.fix(&ids, dof::ALL, false).map_err(raise)?;
            Ok(ids.len() as INT)
        });
}

/// A finite number from a script value (an int or a float).
pub(super) fn finite(v: &Dynamic, what: &str) -> RhaiResult<f64> {
    match number(v) {
        Some(x) if x.is_finite() => Ok(x),
        Some(x) => Err(err(format!("{what} must be a finite number, got {x}"))),
        None => Err(err(format!("{what} must be a number, got {}", v.type_name()))),
    }
}

/// Adds one element per row of `t` (columns x, y, z, r, in m) with material `mat` (a name
/// the model knows, or a material value) to group `group` (created, or extended). Every
/// row is checked before any element is added. Returns the number added.
fn add_elements(m: &mut Model, t: &Table, mat: &Dynamic, group: &str) -> RhaiResult<INT> {
    let data = t.0.borrow();
    let cols = ["x", "y", "z", "r"].map(|c| {
        data.column(c).map_err(|e| match *e {
            EvalAltResult::ErrorRuntime(msg, _) => {
                err(format!("add_elements: {msg}; give a table with columns x, y, z, r"))
            }
            other => Box::new(other),
        })
    });
    let [x, y, z, r] = cols;
    let (x, y, z, r) = (x?, y?, z?, r?);
    let rows = x.len();
    if [y.len(), z.len(), r.len()].iter().any(|&l| l != rows) {
        return Err(err("add_elements: the columns x, y, z and r must have the same length"));
    }
    for k in 0..rows {
        let vals = [("x", x[k]), ("y", y[k]), ("z", z[k]), ("r", r[k])];
        if let Some((c, v)) = vals.iter().find(|(c, v)| !v.is_finite() || (*c == "r" && *v <= 0.0)) {
            let what = if *c == "r" { "a finite radius > 0 m" } else { "a finite coordinate, m" };
            return Err(err(format!(
                "add_elements: table row {k} (0-based, after the header) has {c} = {v}; it must be {what}; \
                 nothing was added"
            )));
        }
    }
    let pos: Vec<Vec3> = (0..rows).map(|k| Vec3::new(x[k], y[k], z[k])).collect();
    add_checked(m, &pos, r, mat, group)
}

/// Adds elements at checked centres and radii with material `mat` (a name the model knows,
/// or a material value) to group `group` (created, or extended). Returns the number added.
fn add_checked(m: &mut Model, pos: &[Vec3], r: &[f64], mat: &Dynamic, group: &str) -> RhaiResult<INT> {
    super::groups::check_group_name("add_elements", group)?;
    let material = if let Some(name) = mat.clone().try_cast::<rhai::ImmutableString>() {
        m.material_index(&name).map_err(|e| {
            err(format!(
                "add_elements: {e}; give it to a group first with d.set_group_mat, or pass the material itself"
            ))
        })?
    } else if let Some(mat) = mat.clone().try_cast::<Material>() {
        m.add_material(mat).map_err(raise)?
    } else {
        return Err(err(format!("add_elements: expected a material name or a material, got {}", mat.type_name())));
    };
    let mut ids: Vec<u32> = m.groups.get(group).map(|g| g.to_vec()).unwrap_or_default();
    for (p, r) in pos.iter().zip(r) {
        let id = m.add_particle(*p, *r, material).map_err(raise)?;
        ids.push(id as u32);
    }
    m.groups.set(group, ids);
    Ok(pos.len() as INT)
}
