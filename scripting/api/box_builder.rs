//! The box builder (MatDEM: `B = obj_Box`): sample size, container, gradation and platens;
//! `build_initial_model()` fills the container loosely and returns the model `d`.

use super::arrays::to_numbers;
use super::model::ModelHandle;
use super::{err, raise, Host, RhaiResult};
use matdem_engine::builder::{BoxSpec, Container, SizeClass};
use matdem_engine::{Material, Model};
use rhai::{Array, Engine, FLOAT, INT};
use std::cell::RefCell;
use std::rc::Rc;

#[derive(Clone)]
pub struct BoxData {
    pub name: String,
    pub ball_r: f64,
    pub distri_rate: f64,
    pub gradation: Vec<SizeClass>,
    pub sample_w: f64,
    pub sample_l: f64,
    pub sample_h: f64,
    /// Cylinder radius; > 0 makes a cylindrical sample (the oedometer ring).
    pub sample_r: f64,
    pub porosity: f64,
    pub seed: u64,
    pub top_platen: bool,
    pub material: Option<Material>,
    pub model: Option<ModelHandle>,
}

#[derive(Clone)]
pub struct BoxBuilder(pub Rc<RefCell<BoxData>>);

impl BoxBuilder {
    fn new(name: &str) -> Self {
        BoxBuilder(Rc::new(RefCell::new(BoxData {
            name: name.to_string(),
            ball_r: 1e-3,
            distri_rate: 0.2,
            gradation: Vec::new(),
            sample_w: 0.02,
            sample_l: 0.02,
            sample_h: 0.02,
            sample_r: 0.0,
            porosity: 0.4,
            seed: 1,
            top_platen: false,
            material: None,
            model: None,
        })))
    }
}

fn finite_positive(name: &str, v: f64) -> RhaiResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(err(format!("{name} must be a finite number > 0, got {v}")))
    }
}

fn build(host: &Host, b: &mut BoxBuilder) -> RhaiResult<ModelHandle> {
    let data = b.0.borrow().clone();
    let classes = if data.gradation.is_empty() {
        let r = finite_positive("ball_r", data.ball_r)?;
        if !(0.0..1.0).contains(&data.distri_rate) {
            return Err(err(format!("distri_rate must be in [0, 1), got {}", data.distri_rate)));
        }
        vec![SizeClass { r_min: r * (1.0 - data.distri_rate), r_max: r * (1.0 + data.distri_rate), mass_ratio: 1.0 }]
    } else {
        data.gradation.clone()
    };
    let container = if data.sample_r > 0.0 {
        Container::Cylinder { radius: data.sample_r }
    } else if data.sample_l == 0.0 {
        // MatDEM's `sampleL = 0`: a 2D model in the x–z plane.
        Container::Rectangle { width: data.sample_w }
    } else {
        Container::Cuboid { width: data.sample_w, length: data.sample_l }
    };
    let spec = BoxSpec {
        container,
        height: data.sample_h,
        classes: classes.clone(),
        target_porosity: data.porosity,
        seed: data.seed,
        top_platen: data.top_platen,
    };
    // The gradation is checked first: a NaN radius must be named as such, not as the
    // default material's modulus it would make NaN.
    spec.validate().map_err(raise)?;
    let mut model = Model::new();
    let r_mean = classes.iter().map(|c| 0.5 * (c.r_min + c.r_max)).sum::<f64>() / classes.len() as f64;
    let mat = match data.material {
        Some(m) => m,
        // A soft generic sand so a box builds without a material; scripts set their own.
        None => Material::from_micro("default", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, r_mean).map_err(raise)?,
    };
    model.add_material(mat).map_err(raise)?;
    let built = spec.build_into_until(&mut model, &host.control).map_err(|e| super::raise_build(host, e))?;
    model.groups.set("sample", (0..model.len() as u32).collect());
    for (k, ids) in built.class_ids.into_iter().enumerate() {
        model.groups.set(&format!("class{}", k + 1), ids);
    }
    let handle = host.adopt(&data.name, model);
    b.0.borrow_mut().model = Some(handle.clone());
    Ok(handle)
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<BoxBuilder>("Box");
    engine.register_fn("new_box", |name: &str| BoxBuilder::new(name));
    macro_rules! num_prop {
        ($name:literal, $field:ident) => {
            engine
                .register_get($name, |b: &mut BoxBuilder| b.0.borrow().$field)
                .register_set($name, |b: &mut BoxBuilder, v: FLOAT| -> RhaiResult<()> {
                    if !v.is_finite() || v < 0.0 {
                        return Err(err(format!("{} must be a finite number ≥ 0, got {v}", $name)));
                    }
                    b.0.borrow_mut().$field = v;
                    Ok(())
                })
                .register_set($name, |b: &mut BoxBuilder, v: INT| -> RhaiResult<()> {
                    if v < 0 {
                        return Err(err(format!("{} must be ≥ 0, got {v}", $name)));
                    }
                    b.0.borrow_mut().$field = v as f64;
                    Ok(())
                });
        };
    }
    num_prop!("ball_r", ball_r);
    num_prop!("distri_rate", distri_rate);
    num_prop!("sample_w", sample_w);
    num_prop!("sample_l", sample_l);
    num_prop!("sample_h", sample_h);
    num_prop!("sample_r", sample_r);
    num_prop!("porosity", porosity);
    engine
        .register_set("seed", |b: &mut BoxBuilder, s: INT| -> RhaiResult<()> {
            // A negative seed would wrap to a huge one silently.
            let seed = u64::try_from(s).map_err(|_| err(format!("seed must be 0 or more, got {s}")))?;
            b.0.borrow_mut().seed = seed;
            Ok(())
        })
        .register_get("seed", |b: &mut BoxBuilder| b.0.borrow().seed as INT)
        .register_set("material", |b: &mut BoxBuilder, m: Material| b.0.borrow_mut().material = Some(m))
        .register_set("gradation", |b: &mut BoxBuilder, g: Array| -> RhaiResult<()> {
            let mut classes = Vec::new();
            for (k, row) in g.iter().enumerate() {
                let v = to_numbers(row, &format!("gradation row {k}"))?;
                if v.len() != 3 {
                    return Err(err(format!(
                        "gradation row {k}: expected [r_min, r_max, mass_ratio], got {} numbers",
                        v.len()
                    )));
                }
                classes.push(SizeClass { r_min: v[0], r_max: v[1], mass_ratio: v[2] });
            }
            b.0.borrow_mut().gradation = classes;
            Ok(())
        })
        .register_fn("set_type", |b: &mut BoxBuilder, t: &str| -> RhaiResult<()> {
            match t {
                "top_platen" | "topPlaten" => {
                    b.0.borrow_mut().top_platen = true;
                    Ok(())
                }
                other => Err(raise(matdem_engine::Error::unknown("box type", other, &["top_platen"]))),
            }
        })
        .register_fn("build_initial_model", move |b: &mut BoxBuilder| build(&host, b))
        .register_get("d", |b: &mut BoxBuilder| -> RhaiResult<ModelHandle> {
            b.0.borrow().model.clone().ok_or_else(|| err("the box has no model yet: call build_initial_model() first"))
        })
        .register_get("name", |b: &mut BoxBuilder| b.0.borrow().name.clone())
        .register_get("classes", |b: &mut BoxBuilder| {
            let d = b.0.borrow();
            let n = if d.gradation.is_empty() { 1 } else { d.gradation.len() };
            n as INT
        })
        .register_fn("to_string", |b: &mut BoxBuilder| {
            let d = b.0.borrow();
            format!("Box `{}` ({} × {} × {} m, r = {})", d.name, d.sample_w, d.sample_l, d.sample_h, d.ball_r)
        });
}
