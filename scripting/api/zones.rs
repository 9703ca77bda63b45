//! Variable particle-size models (paper 001) as scripts see them: the zoned builder
//! `new_zoned` (concentric cylindrical zones of growing grain size with mixing layers,
//! groups `zone1…`, `mix12…`), scaled copies of a model (`d.scaled(λ)`, `scale_model`) and
//! the material scaling law (`m.scaled(λ)`, `scaled_material`).

use super::arrays::to_numbers;
use super::model::ModelHandle;
use super::{err, raise, Host, RhaiResult};
use matdem_engine::scaling::{scaled_material, scaled_model};
use matdem_engine::zoned::{zone_report, PackReport, ZoneRegion, ZoneSpec};
use matdem_engine::{Material, Vec3};
use rhai::{Array, Dynamic, Engine, Map, FLOAT, INT};
use std::cell::RefCell;
use std::rc::Rc;

#[derive(Clone)]
pub struct ZonedData {
    pub name: String,
    pub spec: ZoneSpec,
    pub material: Option<Material>,
    pub scale_stiffness: bool,
    pub regions: Vec<ZoneRegion>,
    pub model: Option<ModelHandle>,
    /// How the last build's packing went, and the grains it put in each region.
    pub pack: Option<(PackReport, Vec<(String, usize)>)>,
}

/// A zoned builder (shared: every variable holding it sees the same one, as a box's).
#[derive(Clone)]
pub struct ZonedBuilder(pub Rc<RefCell<ZonedData>>);

impl ZonedBuilder {
    fn new(name: &str) -> Self {
        ZonedBuilder(Rc::new(RefCell::new(ZonedData {
            name: name.to_string(),
            spec: ZoneSpec::default(),
            material: None,
            scale_stiffness: true,
            regions: Vec::new(),
            model: None,
            pack: None,
        })))
    }
}

fn numbers(v: &Dynamic, what: &str) -> RhaiResult<Vec<f64>> {
    if let Some(x) = super::arrays::number(v) {
        return Ok(vec![x]);
    }
    to_numbers(v, what)
}

fn build(host: &Host, z: &mut ZonedBuilder) -> RhaiResult<ModelHandle> {
    let data = z.0.borrow().clone();
    data.spec.validate().map_err(raise)?;
    let material = match data.material {
        Some(m) => m,
        // Paper 001 §3: Kn = Ks = 5e5 N/m for 6 mm grains, μ 0.5; scaled to the core's size.
        None => {
            let d1 = data.spec.grain_d[0];
            let m = Material::from_micro("default", 2650.0, 5e5, 5e5, 0.0, 0.0, 0.5, 3e-3).map_err(raise)?;
            scaled_material(&m, d1 / 6e-3).map_err(raise)?
        }
    };
    let (model, regions, pack) =
        data.spec.pack(&material, data.scale_stiffness, &host.control).map_err(|e| super::raise_build(host, e))?;
    let grains = regions.iter().map(|r| (r.name.clone(), model.groups.get(&r.name).map_or(0, |g| g.len()))).collect();
    let handle = host.adopt(&data.name, model);
    let mut d = z.0.borrow_mut();
    d.regions = regions;
    d.model = Some(handle.clone());
    d.pack = Some((pack, grains));
    Ok(handle)
}

/// The last build's packing as a map (see the `pack_report` property).
fn pack_report(z: &ZonedBuilder) -> RhaiResult<Map> {
    let data = z.0.borrow();
    let (r, grains) =
        data.pack.as_ref().ok_or_else(|| err("the zoned model is not built yet: call build_initial_model() first"))?;
    let mut m = Map::new();
    m.insert("steps".into(), ((r.growth_steps + r.settle_steps) as INT).into());
    m.insert("growth_steps".into(), (r.growth_steps as INT).into());
    m.insert("settle_steps".into(), (r.settle_steps as INT).into());
    m.insert("settled".into(), r.settled.into());
    m.insert("capped".into(), (!r.settled).into());
    m.insert("ratio".into(), r.unbalanced_ratio.into());
    m.insert("mean_speed".into(), r.mean_speed.into());
    m.insert("deepest_stray".into(), r.deepest_stray.into());
    let mut per = Map::new();
    for (name, n) in grains {
        per.insert(name.as_str().into(), (*n as INT).into());
    }
    m.insert("grains".into(), per.into());
    Ok(m)
}

/// The grains a build of the zones as set now will make, before packing (the solid volume
/// at each region's target porosity over its grains' mean volume; the build's own count
/// differs by its random draw), so that a script can say what a chamber costs before it
/// packs one.
fn expected_grains(z: &ZonedBuilder) -> RhaiResult<INT> {
    let data = z.0.borrow();
    data.spec.validate().map_err(raise)?;
    let n: usize = data.spec.counts().iter().flat_map(|(_, sizes)| sizes.iter().map(|&(_, n)| n)).sum();
    Ok(n as INT)
}

fn report(z: &ZonedBuilder) -> RhaiResult<Array> {
    let data = z.0.borrow();
    let handle =
        data.model.clone().ok_or_else(|| err("the zoned model is not built yet: call build_initial_model() first"))?;
    let d = handle.data();
    let rows = zone_report(&d.sim.model, &data.regions, &data.spec.grain_d);
    Ok(rows
        .into_iter()
        .map(|r| {
            let mut m = Map::new();
            m.insert("name".into(), r.name.into());
            m.insert("r_in".into(), r.r_in.into());
            m.insert("r_out".into(), r.r_out.into());
            m.insert("count".into(), (r.count as INT).into());
            m.insert("porosity".into(), r.porosity.into());
            m.insert("target_porosity".into(), r.target_porosity.into());
            m.insert("coordination".into(), r.coordination.into());
            Dynamic::from_map(m)
        })
        .collect())
}

fn scaled_copy(host: &Host, d: &ModelHandle, lambda: f64, materials: bool) -> RhaiResult<ModelHandle> {
    let (name, model) = {
        let data = d.data();
        (
            format!("{}_x{lambda}", data.name),
            scaled_model(&data.sim.model, lambda, Vec3::zeros(), materials).map_err(raise)?,
        )
    };
    Ok(host.adopt(&name, model))
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<ZonedBuilder>("Zoned");
    engine.register_fn("new_zoned", |name: &str| ZonedBuilder::new(name));
    macro_rules! list_prop {
        ($name:literal, $field:ident) => {
            engine
                .register_get($name, |z: &mut ZonedBuilder| -> Array {
                    z.0.borrow().spec.$field.iter().map(|&v| Dynamic::from(v)).collect()
                })
                .register_set($name, |z: &mut ZonedBuilder, v: Dynamic| -> RhaiResult<()> {
                    let v = numbers(&v, $name)?;
                    z.0.borrow_mut().spec.$field = v;
                    Ok(())
                });
        };
    }
    list_prop!("radius", radius);
    list_prop!("grain_d", grain_d);
    list_prop!("mix", mix);
    macro_rules! num_prop {
        ($name:literal, $field:ident) => {
            engine.register_get($name, |z: &mut ZonedBuilder| z.0.borrow().spec.$field).register_set(
                $name,
                |z: &mut ZonedBuilder, v: Dynamic| -> RhaiResult<()> {
                    let x = super::arrays::number(&v)
                        .ok_or_else(|| err(format!("{} must be a number, got {}", $name, v.type_name())))?;
                    if !x.is_finite() || x < 0.0 {
                        return Err(err(format!("{} must be a finite number ≥ 0, got {x}", $name)));
                    }
                    z.0.borrow_mut().spec.$field = x;
                    Ok(())
                },
            );
        };
    }
    num_prop!("height", height);
    num_prop!("porosity", porosity);
    num_prop!("mix_porosity", mix_porosity);
    num_prop!("mix_fine_share", mix_fine_share);
    num_prop!("distri_rate", distri_rate);
    let h = host.clone();
    engine
        .register_set("seed", |z: &mut ZonedBuilder, s: INT| -> RhaiResult<()> {
            let seed = u64::try_from(s).map_err(|_| err(format!("seed must be 0 or more, got {s}")))?;
            z.0.borrow_mut().spec.seed = seed;
            Ok(())
        })
        .register_get("seed", |z: &mut ZonedBuilder| z.0.borrow().spec.seed as INT)
        .register_set("material", |z: &mut ZonedBuilder, m: Material| z.0.borrow_mut().material = Some(m))
        .register_set("scale_stiffness", |z: &mut ZonedBuilder, on: bool| z.0.borrow_mut().scale_stiffness = on)
        .register_get("scale_stiffness", |z: &mut ZonedBuilder| z.0.borrow().scale_stiffness)
        .register_fn("build_initial_model", move |z: &mut ZonedBuilder| build(&h, z))
        .register_get("d", |z: &mut ZonedBuilder| -> RhaiResult<ModelHandle> {
            z.0.borrow()
                .model
                .clone()
                .ok_or_else(|| err("the zoned model is not built yet: call build_initial_model() first"))
        })
        .register_get("pack_report", |z: &mut ZonedBuilder| pack_report(z))
        .register_get("expected_grains", |z: &mut ZonedBuilder| expected_grains(z))
        .register_get("name", |z: &mut ZonedBuilder| z.0.borrow().name.clone())
        .register_get("regions", |z: &mut ZonedBuilder| -> Array {
            let d = z.0.borrow();
            let regions = if d.regions.is_empty() { d.spec.regions() } else { d.regions.clone() };
            regions.into_iter().map(|r| Dynamic::from(r.name)).collect()
        })
        .register_fn("to_string", |z: &mut ZonedBuilder| {
            let d = z.0.borrow();
            format!(
                "Zoned `{}` (radius {:?} m, grain_d {:?} m, mix {:?} m, height {} m)",
                d.name, d.spec.radius, d.spec.grain_d, d.spec.mix, d.spec.height
            )
        });
    let h = host.clone();
    engine.register_fn("zone_report", move |z: &mut ZonedBuilder| -> RhaiResult<Dynamic> {
        let z = z.clone();
        h.observe("zone_report", || report(&z).map(Dynamic::from_array))
    });

    // Scaled copies: the law (materials too) by default, geometry only on request.
    let h = host.clone();
    engine.register_fn("scaled", move |d: &mut ModelHandle, lambda: FLOAT| scaled_copy(&h, d, lambda, true));
    let h = host.clone();
    engine.register_fn("scaled", move |d: &mut ModelHandle, lambda: INT| scaled_copy(&h, d, lambda as f64, true));
    let h = host.clone();
    engine.register_fn("scaled", move |d: &mut ModelHandle, lambda: FLOAT, materials: bool| {
        scaled_copy(&h, d, lambda, materials)
    });
    let h = host.clone();
    engine.register_fn("scale_model", move |d: ModelHandle, lambda: FLOAT| scaled_copy(&h, &d, lambda, true));
    let h = host;
    engine.register_fn("scale_model", move |d: ModelHandle, lambda: INT| scaled_copy(&h, &d, lambda as f64, true));
    engine
        .register_fn("scaled", |m: &mut Material, lambda: FLOAT| scaled_material(m, lambda).map_err(raise))
        .register_fn("scaled", |m: &mut Material, lambda: INT| scaled_material(m, lambda as f64).map_err(raise))
        .register_fn("scaled_material", |m: Material, lambda: FLOAT| scaled_material(&m, lambda).map_err(raise))
        .register_fn("scaled_material", |m: Material, lambda: INT| scaled_material(&m, lambda as f64).map_err(raise));
}
