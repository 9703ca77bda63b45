//! Materials as scripts see them (MatDEM: `material(name, matTxt, ballR)`): from macro
//! properties through the lattice formulas, or from micro values directly.

use super::field::number;
use super::{err, raise, RhaiResult};
use matdem_engine::materials::{MacroProperties, Material};
use rhai::{Engine, Map, FLOAT};

const MACRO_KEYS: &[&str] = &["E", "nu", "Tu", "Cu", "mu_i", "density", "d", "restitution"];
const MICRO_KEYS: &[&str] = &["kn", "ks", "xb", "fs0", "mu_p", "density", "r", "young", "poisson", "restitution"];

/// Reads the numbers of `map`, refusing unknown keys with the known ones listed.
fn read(map: &Map, known: &[&str], what: &str) -> RhaiResult<Vec<(String, f64)>> {
    map.iter()
        .map(|(k, v)| {
            let key = k.as_str();
            if !known.contains(&key) {
                let e = matdem_engine::Error::unknown("material key", key, known);
                return Err(err(format!("{what}: {e}")));
            }
            let x = number(v).ok_or_else(|| err(format!("{what}: `{key}` must be a number, got {}", v.type_name())))?;
            Ok((key.to_string(), x))
        })
        .collect()
}

fn get(vals: &[(String, f64)], key: &str, what: &str) -> RhaiResult<f64> {
    vals.iter().find(|(k, _)| k == key).map(|(_, v)| *v).ok_or_else(|| err(format!("{what}: missing `{key}`")))
}

fn opt(vals: &[(String, f64)], key: &str) -> Option<f64> {
    vals.iter().find(|(k, _)| k == key).map(|(_, v)| *v)
}

/// `material(name, #{E, nu, Tu, Cu, mu_i, density, d})`: macro → micro for elements of diameter d.
fn material_macro(name: &str, map: Map) -> RhaiResult<Material> {
    let what = format!("material(\"{name}\")");
    let v = read(&map, MACRO_KEYS, &what)?;
    let p = MacroProperties {
        young: get(&v, "E", &what)?,
        poisson: get(&v, "nu", &what)?,
        tensile: opt(&v, "Tu").unwrap_or(0.0),
        compressive: get(&v, "Cu", &what)?,
        internal_friction: get(&v, "mu_i", &what)?,
    };
    let mut m =
        Material::from_macro(name, opt(&v, "density").unwrap_or(2650.0), &p, get(&v, "d", &what)?).map_err(raise)?;
    if let Some(e) = opt(&v, "restitution") {
        m.restitution = e;
    }
    m.validate().map_err(raise)?;
    Ok(m)
}

/// `material_micro(name, #{kn, ks, xb, fs0, mu_p, density, r})`: micro values directly;
/// Hertz uses E = Kn/(π·r), ν = 0 (paper 000) unless `young`/`poisson` are given.
fn material_micro(name: &str, map: Map) -> RhaiResult<Material> {
    let what = format!("material_micro(\"{name}\")");
    let v = read(&map, MICRO_KEYS, &what)?;
    let mut m = Material::from_micro(
        name,
        opt(&v, "density").unwrap_or(2650.0),
        get(&v, "kn", &what)?,
        opt(&v, "ks").unwrap_or(0.0),
        opt(&v, "xb").unwrap_or(0.0),
        opt(&v, "fs0").unwrap_or(0.0),
        opt(&v, "mu_p").unwrap_or(0.0),
        get(&v, "r", &what)?,
    )
    .map_err(raise)?;
    if let Some(e) = opt(&v, "young") {
        m.young = e;
    }
    if let Some(nu) = opt(&v, "poisson") {
        m.poisson = nu;
    }
    if let Some(e) = opt(&v, "restitution") {
        m.restitution = e;
    }
    m.validate().map_err(raise)?;
    Ok(m)
}

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<Material>("Material");
    engine
        .register_fn("material", material_macro)
        .register_fn("material_micro", material_micro)
        .register_get("name", |m: &mut Material| m.name.clone())
        .register_get("kn", |m: &mut Material| m.kn)
        .register_get("ks", |m: &mut Material| m.ks)
        .register_get("xb", |m: &mut Material| m.xb)
        .register_get("fs0", |m: &mut Material| m.fs0)
        .register_get("mu_p", |m: &mut Material| m.mu_p)
        .register_get("young", |m: &mut Material| m.young)
        .register_get("poisson", |m: &mut Material| m.poisson)
        .register_get("density", |m: &mut Material| m.density)
        .register_get("restitution", |m: &mut Material| m.restitution);
    macro_rules! setter {
        ($name:literal, $field:ident) => {
            engine.register_set($name, |m: &mut Material, v: FLOAT| -> RhaiResult<()> {
                let old = m.$field;
                m.$field = v;
                if let Err(e) = m.validate() {
                    m.$field = old;
                    return Err(raise(e));
                }
                Ok(())
            });
        };
    }
    setter!("kn", kn);
    setter!("ks", ks);
    setter!("xb", xb);
    setter!("fs0", fs0);
    setter!("mu_p", mu_p);
    setter!("young", young);
    setter!("poisson", poisson);
    setter!("density", density);
    setter!("restitution", restitution);
    engine
        .register_fn("to_string", |m: &mut Material| describe(m))
        .register_fn("to_debug", |m: &mut Material| describe(m))
        .register_fn("macro_properties", |m: &mut Material, d: FLOAT| {
            let p = m.lattice_macro(d);
            let mut map = Map::new();
            map.insert("E".into(), p.young.into());
            map.insert("nu".into(), p.poisson.into());
            map.insert("Tu".into(), p.tensile.into());
            map.insert("Cu".into(), p.compressive.into());
            map.insert("mu_i".into(), p.internal_friction.into());
            map
        });
}

fn describe(m: &Material) -> String {
    format!(
        "Material `{}`: Kn {:.4e} N/m, Ks {:.4e} N/m, Xb {:.4e} m, Fs0 {:.4e} N, μp {:.4}, E {:.4e} Pa, ν {:.3}, ρ {} kg/m³, e {}",
        m.name, m.kn, m.ks, m.xb, m.fs0, m.mu_p, m.young, m.poisson, m.density, m.restitution
    )
}
