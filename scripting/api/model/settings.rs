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
            d.model().settings.gravity = vec3(&Dynamic::from_array(g), "gravity")?;
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
        .register_fn("enable", |d: &mut ModelHandle, effect: &str| -> RhaiResult<()> {
            let mut m = d.model();
            match effect {
                "rotation" => {
                    m.settings.rotation = true;
                    m.particles.enable_rotation();
                    Ok(())
                }
                "heat" => {
                    m.enable_heat();
                    Ok(())
                }
                other => Err(raise(matdem_engine::Error::unknown("effect", other, &["rotation", "heat"]))),
            }
        })
        .register_fn("disable", |d: &mut ModelHandle, effect: &str| -> RhaiResult<()> {
            let mut m = d.model();
            match effect {
                // The lanes stay (a later enable continues from them); the plan drops the stage.
                "heat" => m.settings.heat.enabled = false,
                "water" => m.settings.water.level = None,
                other => return Err(raise(matdem_engine::Error::unknown("effect", other, &["heat", "water"]))),
            }
            Ok(())
        })
        .register_fn("plan", |d: &mut ModelHandle| d.data().sim.plan().to_string());
}
