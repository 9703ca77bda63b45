//! Groups (MatDEM `d.GROUP`), materials, fixed degrees of freedom, removal and bonds.

use super::*;

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_fn("add_group", |d: &mut ModelHandle, name: &str, sel: Dynamic| -> RhaiResult<INT> {
            check_group_name("add_group", name)?;
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            let n = ids.len();
            m.groups.set(name, ids);
            Ok(n as INT)
        })
        .register_fn("group_where", |d: &mut ModelHandle, name: &str, mask: Mask| -> RhaiResult<INT> {
            check_group_name("group_where", name)?;
            let mut m = d.model();
            let ids = resolve_ids(&m, &Dynamic::from(mask))?;
            let n = ids.len();
            m.groups.set(name, ids);
            Ok(n as INT)
        })
        .register_fn("group", |d: &mut ModelHandle, name: &str| -> RhaiResult<Array> {
            let m = d.model();
            Ok(m.groups.get(name).map_err(raise)?.iter().map(|&i| Dynamic::from_int(i as INT)).collect())
        })
        .register_fn("in_group", |d: &mut ModelHandle, name: &str| -> RhaiResult<Mask> {
            let m = d.model();
            let mut mask = vec![false; m.len()];
            for &i in m.groups.get(name).map_err(raise)? {
                mask[i as usize] = true;
            }
            Ok(Mask::new(mask))
        })
        .register_get("groups", |d: &mut ModelHandle| {
            d.model().groups.names().map(|s| Dynamic::from(s.to_string())).collect::<Array>()
        })
        .register_fn("set_group_mat", |d: &mut ModelHandle, sel: Dynamic, mat: Material| -> RhaiResult<()> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            let k = m.add_material(mat).map_err(raise)?;
            m.set_material(&ids, k).map_err(raise)
        })
        .register_fn("fix", |d: &mut ModelHandle, sel: Dynamic, axes: &str| -> RhaiResult<()> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            m.fix(&ids, dofs(axes)?, true).map_err(raise)
        })
        .register_fn("free", |d: &mut ModelHandle, sel: Dynamic, axes: &str| -> RhaiResult<()> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            m.fix(&ids, dofs(axes)?, false).map_err(raise)
        })
        .register_fn("set_velocity", |d: &mut ModelHandle, sel: Dynamic, v: Array| -> RhaiResult<()> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            let v = vec3(&Dynamic::from_array(v), "velocity")?;
            // A killed element stays at rest (its blocked degrees of freedom would keep a velocity).
            if let Some(&i) = ids.iter().find(|&&i| m.is_killed(i as usize)) {
                return Err(err(format!(
                    "set_velocity: particle {i} was killed (d.kill) and stays at rest; leave the killed elements out \
                     of the selection; nothing was changed"
                )));
            }
            for i in ids {
                m.particles.vel[i as usize] = v;
            }
            Ok(())
        })
        .register_fn("remove", |d: &mut ModelHandle, sel: Dynamic| -> RhaiResult<INT> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            m.remove_particles(&ids).map_err(raise)?;
            Ok(ids.len() as INT)
        })
        .register_fn(
            "connect",
            observed!(host, "connect", |d, sel: Dynamic, tol: FLOAT| {
                let mut m = d.model();
                let ids = resolve_ids(&m, &sel)?;
                m.connect(Some(&ids), tol).map_err(raise)? as INT
            }),
        )
        .register_fn(
            "connect",
            observed!(host, "connect", |d, a: Dynamic, b: Dynamic, tol: FLOAT| {
                let mut m = d.model();
                let (a, b) = (resolve_ids(&m, &a)?, resolve_ids(&m, &b)?);
                m.connect_between(&a, &b, tol).map_err(raise)? as INT
            }),
        )
        .register_fn(
            "break_bonds",
            observed!(host, "break_bonds", |d, sel: Dynamic| {
                let mut m = d.model();
                let ids = resolve_ids(&m, &sel)?;
                m.break_bonds(Some(&ids)).map_err(raise)? as INT
            }),
        )
        // d.bond_parallel(#{ lambda, e_star, k_ratio, sigma_c, c, phi }) -> bonds: every bond of
        // the model becomes a parallel bond (Potyondy & Cundall 2004, docs/parallel-bond.md) of
        // radius lambda·min(Ri, Rj), bond modulus e_star (Pa), stiffness ratio k_ratio = k̄n/k̄s,
        // tensile strength sigma_c (Pa), cohesion c (Pa) and friction angle phi (degrees), in
        // parallel with the plain linear contact; rotation is switched on. All six keys are
        // needed; an unknown key, a bad value or a model without bonds is refused.
        .register_fn(
            "bond_parallel",
            observed!(host, "bond_parallel", |d, p: Map| {
                let params = parallel_bond_params(&p)?;
                d.model().bond_parallel(params).map_err(raise)? as INT
            }),
        )
        .register_get("parallel_bonds", observed!(host, "parallel_bonds", |d| d.model().parallel_bonds.intact() as INT))
        .register_get("bonds", observed!(host, "bonds", |d| d.model().bond_count() as INT))
        .register_get("broken_bonds", observed!(host, "broken_bonds", |d| d.model().breakages.len() as INT));
}

/// The keys of `d.bond_parallel`'s map, in the order the docs give them.
const PARALLEL_BOND_KEYS: [&str; 6] = ["lambda", "e_star", "k_ratio", "sigma_c", "c", "phi"];

/// `d.bond_parallel`'s map as the engine's parameters (phi from degrees), refusing unknown or
/// missing keys and values that are not numbers; the engine checks the ranges.
fn parallel_bond_params(map: &Map) -> RhaiResult<matdem_engine::effects::parallel_bond::physics::ParallelBondParams> {
    let what = "bond_parallel";
    for k in map.keys() {
        if !PARALLEL_BOND_KEYS.contains(&k.as_str()) {
            let e = matdem_engine::Error::unknown("parallel bond key", k.as_str(), &PARALLEL_BOND_KEYS);
            return Err(err(format!("{what}: {e}")));
        }
    }
    let get = |key: &str| -> RhaiResult<f64> {
        let v = map
            .get(key)
            .ok_or_else(|| err(format!("{what}: missing `{key}` (give all of {})", PARALLEL_BOND_KEYS.join(", "))))?;
        number(v).ok_or_else(|| err(format!("{what}: `{key}` must be a number, got {}", v.type_name())))
    };
    Ok(matdem_engine::effects::parallel_bond::physics::ParallelBondParams {
        lambda: get("lambda")?,
        e_star: get("e_star")?,
        k_ratio: get("k_ratio")?,
        sigma_c: get("sigma_c")?,
        cohesion: get("c")?,
        phi: get("phi")?.to_radians(),
    })
}

/// A group made by a script needs a name it can be found by (and shown under) again.
pub(super) fn check_group_name(what: &str, name: &str) -> RhaiResult<()> {
    if name.trim().is_empty() {
        return Err(err(format!("{what}: a group needs a name (got {name:?}); give one such as \"top\"")));
    }
    Ok(())
}
