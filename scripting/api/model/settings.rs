//! Scene settings a script reads and sets: time step, gravity, damping, contact laws, effects.

use super::*;

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_get("time", observed!(host, "time", |d| d.model().clock.time))
        .register_get("step", observed!(host, "step", |d| d.model().clock.step as INT))
        .register_get("dt", |d: &mut ModelHandle| d.model().clock.dt)
        .register_set("dt", |d: &mut ModelHandle, dt: FLOAT| d.model().set_dt(dt).map_err(raise))
        .register_fn("set_standard_dt", |d: &mut ModelHandle| d.model().set_standard_dt().map_err(raise))
        .register_fn("standard_dt", |d: &mut ModelHandle| d.model().standard_dt().map_err(raise))
        .register_fn("critical_dt", |d: &mut ModelHandle| -> RhaiResult<FLOAT> {
            d.model()
                .critical_dt()
                .map(|c| c.1)
                .ok_or_else(|| err("critical_dt: the model has no particles; add some first"))
        })
        .register_get("gravity", |d: &mut ModelHandle| {
            let g = d.model().settings.gravity;
            vec![Dynamic::from_float(g.x), Dynamic::from_float(g.y), Dynamic::from_float(g.z)]
        })
        .register_set("gravity", |d: &mut ModelHandle, g: Array| -> RhaiResult<()> {
            let g = vec3(&Dynamic::from_array(g), "gravity")?;
            // Changing gravity changes the elements' potential where they stand: the energy
            // account books it as body work, before and after the change.
            let mut m = d.model();
            m.book_body_work();
            m.settings.gravity = g;
            m.book_body_work();
            Ok(())
        })
        .register_get("damping", |d: &mut ModelHandle| d.model().settings.damping)
        .register_set("damping", |d: &mut ModelHandle, z: FLOAT| -> RhaiResult<()> {
            if !(0.0..=1.0).contains(&z) {
                return Err(err(format!("damping is a ratio of critical damping in [0, 1], got {z}")));
            }
            d.model().settings.damping = z;
            Ok(())
        })
        .register_get("local_damping", |d: &mut ModelHandle| d.model().settings.local_damping)
        .register_set("local_damping", |d: &mut ModelHandle, a: FLOAT| -> RhaiResult<()> {
            if !(0.0..1.0).contains(&a) {
                return Err(err(format!("local_damping is Cundall's α in [0, 1) (0.7 is usual), got {a}")));
            }
            d.model().settings.local_damping = a;
            Ok(())
        })
        .register_get("heat_ledger", |d: &mut ModelHandle| d.model().settings.heat_ledger)
        .register_set("heat_ledger", |d: &mut ModelHandle, on: bool| d.model().settings.heat_ledger = on)
        .register_set("contact_law", |d: &mut ModelHandle, s: &str| -> RhaiResult<()> {
            d.model().settings.normal = s.parse().map_err(raise)?;
            Ok(())
        })
        .register_set("guard", |d: &mut ModelHandle, s: &str| -> RhaiResult<()> {
            d.model().settings.guard = s.parse().map_err(raise)?;
            Ok(())
        })
        .register_set("shear_law", |d: &mut ModelHandle, s: &str| -> RhaiResult<()> {
            d.model().settings.tangential = s.parse().map_err(raise)?;
            Ok(())
        })
        // d.rolling_resistance = #{ model: "cdt" | "epsd", mu_r: 0.1, damping: 0.3 } (damping: epsd
        // only, optional); () or mu_r: 0 switches it off. Read back as the same map, or ().
        .register_set("rolling_resistance", |d: &mut ModelHandle, r: Map| -> RhaiResult<()> {
            d.model().settings.rolling = Some(rolling_resistance(&r)?);
            Ok(())
        })
        .register_set("rolling_resistance", |d: &mut ModelHandle, _: ()| d.model().settings.rolling = None)
        .register_get("rolling_resistance", |d: &mut ModelHandle| -> Dynamic {
            match d.model().settings.rolling {
                Some(r) => {
                    let mut m = Map::new();
                    m.insert("model".into(), r.model.name().into());
                    m.insert("mu_r".into(), Dynamic::from_float(r.mu_r));
                    m.insert("damping".into(), Dynamic::from_float(r.damping));
                    Dynamic::from_map(m)
                }
                None => Dynamic::UNIT,
            }
        })
        // The effects a script switches by name are the registry's (`Entry::switch`); rotation
        // is the core's.
        .register_fn("enable", |d: &mut ModelHandle, effect: &str| -> RhaiResult<()> {
            let mut m = d.model();
            if effect == "rotation" {
                m.settings.rotation = true;
                m.particles.enable_rotation();
                return Ok(());
            }
            let on = switches().filter_map(|s| Some((s.name, s.enable?)));
            match on.clone().find(|(name, _)| *name == effect) {
                Some((_, enable)) => enable(&mut m).map_err(|e| err(format!("d.enable(\"{effect}\"): {e}"))),
                None => {
                    let known: Vec<&str> = std::iter::once("rotation").chain(on.map(|(name, _)| name)).collect();
                    Err(raise(matdem_engine::Error::unknown("effect", effect, &known)))
                }
            }
        })
        .register_fn("disable", |d: &mut ModelHandle, effect: &str| -> RhaiResult<()> {
            match switches().find(|s| s.name == effect) {
                Some(s) => {
                    (s.disable)(&mut d.model());
                    Ok(())
                }
                None => {
                    let known: Vec<&str> = switches().map(|s| s.name).collect();
                    Err(raise(matdem_engine::Error::unknown("effect", effect, &known)))
                }
            }
        })
        .register_fn("plan", |d: &mut ModelHandle| d.data().sim.plan_text());
}

/// The effects a script switches by name, in step order.
fn switches() -> impl Iterator<Item = matdem_engine::plan::Switch> + Clone {
    matdem_engine::plan::REGISTRY.iter().filter_map(|e| e.switch)
}

/// The keys of `d.rolling_resistance`'s map.
const ROLLING_KEYS: [&str; 3] = ["model", "mu_r", "damping"];

/// `d.rolling_resistance`'s map as the engine's setting, refusing unknown keys, a missing model
/// or mu_r, and values that are not what they should be (the engine checks the ranges).
fn rolling_resistance(map: &Map) -> RhaiResult<matdem_engine::effects::rolling_resistance::physics::RollingResistance> {
    use matdem_engine::effects::rolling_resistance::physics::{RollingModel, RollingResistance};
    let what = "rolling_resistance";
    for k in map.keys() {
        if !ROLLING_KEYS.contains(&k.as_str()) {
            let e = matdem_engine::Error::unknown("rolling resistance key", k.as_str(), &ROLLING_KEYS);
            return Err(err(format!("{what}: {e}")));
        }
    }
    let model = match map.get("model") {
        None => return Err(err(format!("{what}: missing `model` (give model: \"cdt\" or \"epsd\", and mu_r)"))),
        Some(v) => match v.clone().into_immutable_string() {
            Ok(s) => RollingModel::parse(&s).map_err(|e| err(format!("{what}: {e}")))?,
            Err(t) => return Err(err(format!("{what}: `model` must be a string, \"cdt\" or \"epsd\", got {t}"))),
        },
    };
    let num = |key: &str| -> RhaiResult<Option<f64>> {
        match map.get(key) {
            None => Ok(None),
            Some(v) => number(v)
                .map(Some)
                .ok_or_else(|| err(format!("{what}: `{key}` must be a number, got {}", v.type_name()))),
        }
    };
    let mu_r = num("mu_r")?.ok_or_else(|| err(format!("{what}: missing `mu_r` (e.g. mu_r: 0.1)")))?;
    let damping = num("damping")?.unwrap_or(0.0);
    RollingResistance::new(model, mu_r, damping).map_err(|e| err(format!("{what}: {e}")))
}
