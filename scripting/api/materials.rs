//! Materials as scripts see them (MatDEM: `material(name, matTxt, ballR)`): from macro
//! properties through the lattice formulas, or from micro values directly.

use super::arrays::number;
use super::training::properties_map;
use super::{err, raise, RhaiResult};
use matdem_engine::materials::{MacroProperties, Material, MicroParameters};
use matdem_engine::provenance::Source;
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
    converted(name, map, "material", Material::from_macro)
}

/// `material_2d(name, #{…})`: as `material`, through the 2D hexagonal lattice's formulas
/// (MatDEM's `macroToMicro2`), for a 2D model of elements of diameter d.
fn material_2d(name: &str, map: Map) -> RhaiResult<Material> {
    converted(name, map, "material_2d", Material::from_macro_2d)
}

type Conversion = fn(&str, f64, &MacroProperties, f64) -> matdem_engine::Result<Material>;

fn converted(name: &str, map: Map, call: &str, convert: Conversion) -> RhaiResult<Material> {
    let what = format!("{call}(\"{name}\")");
    let v = read(&map, MACRO_KEYS, &what)?;
    let p = MacroProperties {
        young: get(&v, "E", &what)?,
        poisson: get(&v, "nu", &what)?,
        tensile: opt(&v, "Tu").unwrap_or(0.0),
        compressive: get(&v, "Cu", &what)?,
        internal_friction: get(&v, "mu_i", &what)?,
    };
    let mut m = convert(name, opt(&v, "density").unwrap_or(2650.0), &p, get(&v, "d", &what)?).map_err(raise)?;
    if let Some(e) = opt(&v, "restitution") {
        m.restitution = e;
        m.provenance.set("restitution", Source::Given);
    }
    if opt(&v, "density").is_none() {
        m.provenance.set("density", Source::Default("2650 kg/m³, quartz".into()));
    }
    m.validate().map_err(raise)?;
    Ok(m)
}

/// `material_micro(name, #{kn, ks, xb, fs0, mu_p, density, r, young, poisson})`: micro values
/// directly. Hertz's E and ν are given together (`young`, `poisson`), or, without them, E is
/// derived from Kn at radius r (E = Kn/(πR), ν = 0, paper 000); Kn may likewise be derived
/// from E at r. Whatever is derived or left at a default is recorded in the material's
/// provenance and shown by `print(m)`.
fn material_micro(name: &str, map: Map) -> RhaiResult<Material> {
    let what = format!("material_micro(\"{name}\")");
    let v = read(&map, MICRO_KEYS, &what)?;
    let hertz = match (opt(&v, "young"), opt(&v, "poisson")) {
        (Some(e), Some(nu)) => Some((e, nu)),
        (None, None) => None,
        (Some(_), None) => {
            return Err(err(format!(
                "{what}: `young` without `poisson` is ambiguous for the Hertz law: give both (ν = 0 is a valid \
                 choice, but say it)"
            )))
        }
        (None, Some(_)) => {
            return Err(err(format!("{what}: `poisson` without `young`: give both, the Hertz law needs E and ν")))
        }
    };
    let radius = opt(&v, "r");
    // Checked as given: a Kn derived from a negative E would be blamed on `kn`.
    if let Some((e, nu)) = hertz {
        if !(e.is_finite() && e > 0.0) {
            return Err(err(format!("{what}: `young` = {e} Pa: Young's modulus must be a finite number > 0")));
        }
        if !(0.0..0.5).contains(&nu) {
            return Err(err(format!("{what}: `poisson` = {nu}: Poisson's ratio must be in [0, 0.5)")));
        }
    }
    let (kn, kn_derived) = match (opt(&v, "kn"), hertz, radius) {
        (Some(kn), _, _) => (kn, false),
        (None, Some((e, _)), Some(r)) => (std::f64::consts::PI * e * r, true),
        (None, _, _) => {
            return Err(err(format!(
                "{what}: missing `kn`: give `kn` (N/m), or `young`, `poisson` and `r` (the element radius, m) to \
                 derive Kn = π·E·R (paper 000, eq. 6)"
            )))
        }
    };
    let micro = MicroParameters {
        kn,
        ks: opt(&v, "ks").unwrap_or(0.0),
        xb: opt(&v, "xb").unwrap_or(0.0),
        fs0: opt(&v, "fs0").unwrap_or(0.0),
        mu_p: opt(&v, "mu_p").unwrap_or(0.0),
    };
    let density = opt(&v, "density").unwrap_or(2650.0);
    let mut m = match (hertz, radius) {
        (Some((e, nu)), _) => Material::from_micro_hertz(name, density, &micro, e, nu),
        (None, Some(r)) => Material::from_micro(name, density, kn, micro.ks, micro.xb, micro.fs0, micro.mu_p, r),
        (None, None) => {
            return Err(err(format!(
                "{what}: the Hertz law needs E and ν: give `young` and `poisson`, or `r` (the element radius, m) to \
                 derive E = Kn/(πR) with ν = 0 (paper 000)"
            )))
        }
    }
    .map_err(raise)?;
    if let Some(e) = opt(&v, "restitution") {
        m.restitution = e;
        m.provenance.set("restitution", Source::Given);
    }
    m.validate().map_err(raise)?;
    let p = &mut m.provenance;
    if kn_derived {
        p.set("kn", Source::Derived(format!("Kn = π·E·R at R = {:.4e} m (paper 000, eq. 6)", radius.unwrap_or(0.0))));
    }
    for (key, meaning) in [
        ("ks", "0, no shear spring"),
        ("xb", "0, bonds break at any tension"),
        ("fs0", "0, bonds carry no shear"),
        ("mu_p", "0, frictionless"),
        ("density", "2650 kg/m³, quartz"),
    ] {
        if opt(&v, key).is_none() {
            p.set(key, Source::Default(meaning.into()));
        }
    }
    Ok(m)
}

pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<Material>("Material");
    engine
        .register_fn("material", material_macro)
        .register_fn("material_2d", material_2d)
        .register_fn("plane_strain", |map: Map| -> RhaiResult<Map> {
            let what = "plane_strain";
            let v = read(&map, &["E", "nu", "Tu", "Cu", "mu_i"], what)?;
            let p = MacroProperties {
                young: get(&v, "E", what)?,
                poisson: get(&v, "nu", what)?,
                tensile: opt(&v, "Tu").unwrap_or(0.0),
                compressive: opt(&v, "Cu").unwrap_or(0.0),
                internal_friction: opt(&v, "mu_i").unwrap_or(0.0),
            };
            if !(p.young.is_finite() && p.young > 0.0 && p.poisson.is_finite() && (0.0..0.5).contains(&p.poisson)) {
                return Err(err(format!(
                    "{what}: give E > 0 Pa and 0 ≤ ν < 0.5, got E {} and ν {}",
                    p.young, p.poisson
                )));
            }
            Ok(properties_map(&matdem_engine::planar::conversion::plane_strain_equivalent(&p)))
        })
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
                m.provenance.set($name, Source::Given);
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
        .register_fn("macro_properties", |m: &mut Material, d: FLOAT| properties_map(&m.lattice_macro(d)))
        .register_fn("macro_properties_2d", |m: &mut Material, d: FLOAT| {
            properties_map(&matdem_engine::planar::conversion::micro_to_macro_2d(&m.micro(), d))
        });
}

/// One line of values, then each value that was not simply given: where it came from.
fn describe(m: &Material) -> String {
    let mut s = format!(
        "Material `{}`: Kn {:.4e} N/m, Ks {:.4e} N/m, Xb {:.4e} m, Fs0 {:.4e} N, μp {:.4}, E {:.4e} Pa, ν {:.3}, ρ {} kg/m³, e {}",
        m.name, m.kn, m.ks, m.xb, m.fs0, m.mu_p, m.young, m.poisson, m.density, m.restitution
    );
    for (key, source) in m.provenance.iter().filter(|(_, s)| **s != Source::Given) {
        s.push_str(&format!("\n  {key}: {source}"));
    }
    s
}
