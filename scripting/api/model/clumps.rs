//! Clumps (the `clumps` stage): rigid groups of elements that move as one body
//! (engine/src/effects/clumps/).

use super::*;

fn vector(v: &Vec3) -> Dynamic {
    Dynamic::from_array(v.iter().map(|&x| Dynamic::from_float(x)).collect())
}

/// `d.clump(sel)`: the elements `sel` names become one clump; its number.
fn clump(d: &mut ModelHandle, sel: Dynamic) -> RhaiResult<INT> {
    let mut m = d.model();
    let ids = resolve_ids(&m, &sel)?;
    Ok(m.clump(&ids).map_err(raise)? as INT)
}

/// `d.replace_with_clumps(sel, template, seed)`: each element of `sel` becomes a clump of the
/// template's spheres `[[x, y, z, r], …]`, scaled into its sphere and turned at random.
fn replace_with_clumps(d: &mut ModelHandle, sel: Dynamic, template: Array, seed: INT) -> RhaiResult<Array> {
    let what = "d.replace_with_clumps";
    let spheres = template
        .iter()
        .map(|s| {
            let n = to_numbers(s, what)?;
            match n[..] {
                [x, y, z, r] => Ok([x, y, z, r]),
                _ => Err(err(format!("{what}: each sphere of the template is [x, y, z, r], got {s}"))),
            }
        })
        .collect::<RhaiResult<Vec<[f64; 4]>>>()?;
    let mut m = d.model();
    let ids = resolve_ids(&m, &sel)?;
    let made = m.replace_with_clumps(&ids, &spheres, seed as u64).map_err(raise)?;
    Ok(made.into_iter().map(|c| Dynamic::from_int(c as INT)).collect())
}

/// `d.clump_info(c)`: the clump's members and rigid body.
fn clump_info(d: &mut ModelHandle, c: INT) -> RhaiResult<Map> {
    let m = d.model();
    let c = usize::try_from(c).map_err(|_| err(format!("d.clump_info: clump numbers start at 0, got {c}")))?;
    let info = m.clump_info(c).map_err(raise)?;
    let mut map = Map::new();
    map.insert(
        "members".into(),
        Dynamic::from_array(info.members.iter().map(|&i| Dynamic::from_int(i as INT)).collect()),
    );
    map.insert("mass".into(), info.mass.into());
    map.insert("centre".into(), vector(&info.centre));
    map.insert("velocity".into(), vector(&info.velocity));
    map.insert("ang_vel".into(), vector(&info.ang_vel));
    map.insert("ang_mom".into(), vector(&info.ang_mom));
    map.insert("inertia".into(), vector(&info.inertia));
    map.insert(
        "orientation".into(),
        Dynamic::from_array(info.orientation.iter().map(|&x| Dynamic::from_float(x)).collect()),
    );
    Ok(map)
}

pub(super) fn register(engine: &mut Engine) {
    engine
        .register_fn("clump", clump)
        .register_fn("replace_with_clumps", replace_with_clumps)
        .register_fn("replace_with_clumps", |d: &mut ModelHandle, sel: Dynamic, t: Array| {
            replace_with_clumps(d, sel, t, 1)
        })
        .register_fn("clump_info", clump_info)
        .register_fn("clump_count", |d: &mut ModelHandle| -> INT { d.model().clumps.len() as INT });
}
