//! Material training as scripts see it (MatDEM's automatic training): `train(targets,
//! options)`, the numerical tests on a packed, bonded sample, trained material files and
//! rescaling to another element size.

use super::arrays::{number, to_numbers};
use super::options::check_keys;
use super::table::Table;
use super::{err, raise, write_atomic, Host, RhaiResult};
use crate::outln;
use crate::plot::LineChart;
use matdem_engine::materials::MacroProperties;
use matdem_engine::training::fit::mohr_coulomb;
use matdem_engine::training::{
    run_test, validate_targets, Dimension, LabTest, Loading, PackedSample, Round, SampleSpec, TestResult, TrainOptions,
    TrainedMaterial, Training,
};
use matdem_engine::{Material, Model};
use rhai::{Array, Dynamic, Engine, Map, FLOAT, INT};
use std::path::PathBuf;
use std::rc::Rc;

/// A packed sample bonded with one material, ready for tests (MatDEM: a trained box).
#[derive(Clone)]
pub struct TestSample(Rc<SampleData>);

struct SampleData {
    material: Material,
    diameter: f64,
    bonded: Model,
    /// Whose lattice formulas say what the sample should show (a 2D sample: the hexagonal layer's).
    dimension: Dimension,
}

const TARGET_KEYS: &[&str] = &["name", "E", "nu", "Tu", "Cu", "mu_i", "density"];
const OPTION_KEYS: &[&str] =
    &["elements", "radius", "distri_rate", "seed", "dimension", "rounds", "confining", "steps_to_peak", "quiet", "out"];

fn num(map: &Map, key: &str, what: &str) -> RhaiResult<Option<f64>> {
    match map.get(key) {
        None => Ok(None),
        Some(v) => {
            number(v).map(Some).ok_or_else(|| err(format!("{what}: `{key}` must be a number, got {}", v.type_name())))
        }
    }
}

fn required(map: &Map, key: &str, what: &str) -> RhaiResult<f64> {
    num(map, key, what)?.ok_or_else(|| err(format!("{what}: missing `{key}` (give E, nu, Tu, Cu and mu_i)")))
}

fn count(map: &Map, key: &str, what: &str) -> RhaiResult<Option<usize>> {
    match num(map, key, what)? {
        Some(v) if v.is_finite() && v >= 0.0 && v.fract() == 0.0 => Ok(Some(v as usize)),
        Some(v) => Err(err(format!("{what}: `{key}` must be a whole number ≥ 0, got {v}"))),
        None => Ok(None),
    }
}

/// The targets map as macro properties, refused with a reason when training cannot start
/// from `dim`'s formulas.
fn targets(map: &Map, dim: Dimension) -> RhaiResult<(String, MacroProperties, f64)> {
    let what = "train";
    check_keys(map, TARGET_KEYS, what)?;
    let name = map.get("name").map(|v| v.to_string()).unwrap_or_else(|| "trained".into());
    let t = MacroProperties {
        young: required(map, "E", what)?,
        poisson: required(map, "nu", what)?,
        tensile: required(map, "Tu", what)?,
        compressive: required(map, "Cu", what)?,
        internal_friction: required(map, "mu_i", what)?,
    };
    validate_targets(&t, dim).map_err(|e| err(format!("train(\"{name}\"): {e}")))?;
    let density = num(map, "density", what)?.unwrap_or(2650.0);
    Ok((name, t, density))
}

/// The keys of `test_sample`'s options.
const SAMPLE_KEYS: &[&str] = &["elements", "radius", "distri_rate", "seed", "dimension"];

/// The keys of `lab_test`'s options.
const LAB_KEYS: &[&str] = &["confining", "expected_peak_strain", "steps_to_peak"];

fn sample_spec(map: &Map, what: &str) -> RhaiResult<SampleSpec> {
    let mut s = SampleSpec::default();
    if let Some(n) = count(map, "elements", what)? {
        s.elements = n;
    }
    if let Some(r) = num(map, "radius", what)? {
        s.radius = r;
    }
    if let Some(r) = num(map, "distri_rate", what)? {
        s.distri_rate = r;
    }
    if let Some(n) = count(map, "seed", what)? {
        s.seed = n as u64;
    }
    s.dimension = dimension(map, what)?;
    s.validate().map_err(|e| err(format!("{what}: {e}")))?;
    Ok(s)
}

/// `dimension: 2` trains (or tests) a 2D sample, one layer in the x–z plane; 3 by default.
fn dimension(map: &Map, what: &str) -> RhaiResult<Dimension> {
    match count(map, "dimension", what)? {
        None | Some(3) => Ok(Dimension::Three),
        Some(2) => Ok(Dimension::Two),
        Some(n) => Err(err(format!("{what}: `dimension` is 2 or 3, got {n}"))),
    }
}

fn options(map: &Map, density: f64) -> RhaiResult<TrainOptions> {
    let what = "train options";
    check_keys(map, OPTION_KEYS, what)?;
    let mut o = TrainOptions { sample: sample_spec(map, what)?, density, ..TrainOptions::default() };
    if let Some(n) = count(map, "rounds", what)? {
        o.max_rounds = n;
    }
    if let Some(v) = map.get("confining") {
        o.confining = to_numbers(v, "confining")?;
    }
    if let Some(s) = num(map, "steps_to_peak", what)? {
        o.steps_to_peak = s;
    }
    o.validate().map_err(|e| err(format!("{what}: {e}")))?;
    Ok(o)
}

/// Macro properties as scripts name them: E, nu, Tu, Cu, mu_i.
pub(super) fn properties_map(p: &MacroProperties) -> Map {
    let mut m = Map::new();
    m.insert("E".into(), p.young.into());
    m.insert("nu".into(), p.poisson.into());
    m.insert("Tu".into(), p.tensile.into());
    m.insert("Cu".into(), p.compressive.into());
    m.insert("mu_i".into(), p.internal_friction.into());
    m
}

fn micro_map(m: &Material) -> Map {
    let mut map = Map::new();
    for (k, v) in [("kn", m.kn), ("ks", m.ks), ("xb", m.xb), ("fs0", m.fs0), ("mu_p", m.mu_p)] {
        map.insert(k.into(), v.into());
    }
    map
}

/// One row per round: inputs of the conversion, micro parameters, measured values, errors.
fn rounds_table(t: &Training) -> Table {
    let table = Table::default();
    for r in &t.rounds {
        let (m, a, tg) = (&r.measured, &r.inputs, &t.targets);
        let row: Vec<(String, f64)> = [
            ("round", r.round as f64),
            ("E", m.young),
            ("nu", m.poisson),
            ("Tu", m.tensile),
            ("Cu", m.compressive),
            ("mu_i", m.internal_friction),
            ("E_error", m.young / tg.young - 1.0),
            ("nu_error", m.poisson - tg.poisson),
            ("Tu_error", m.tensile / tg.tensile - 1.0),
            ("Cu_error", m.compressive / tg.compressive - 1.0),
            ("mu_i_error", m.internal_friction - tg.internal_friction),
            ("score", r.score),
            ("kn", r.material.kn),
            ("ks", r.material.ks),
            ("xb", r.material.xb),
            ("fs0", r.material.fs0),
            ("mu_p", r.material.mu_p),
            ("input_E", a.young),
            ("input_nu", a.poisson),
            ("input_Tu", a.tensile),
            ("input_Cu", a.compressive),
            ("input_mu_i", a.internal_friction),
            ("steps", r.steps as f64),
            ("wall_seconds", r.wall_seconds),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
        table.0.borrow_mut().push(&row);
    }
    table
}

fn round_line(name: &str, r: &Round, t: &MacroProperties) -> String {
    let m = &r.measured;
    format!(
        "train {name} round {}: E {:.3e} ({:+.1}%)  ν {:.3} ({:+.3})  Tu {:.3e} ({:+.1}%)  Cu {:.3e} ({:+.1}%)  μi {:.3} \
         ({:+.3})  [{:.1} s, {} steps]",
        r.round,
        m.young,
        100.0 * (m.young / t.young - 1.0),
        m.poisson,
        m.poisson - t.poisson,
        m.tensile,
        100.0 * (m.tensile / t.tensile - 1.0),
        m.compressive,
        100.0 * (m.compressive / t.compressive - 1.0),
        m.internal_friction,
        m.internal_friction - t.internal_friction,
        r.wall_seconds,
        r.steps
    )
}

fn save_chart(host: &Host, chart: &LineChart, name: &str) -> RhaiResult<()> {
    let path = host.out_path(name)?;
    let written = chart.save(&path).map_err(|e| err(format!("cannot save `{name}`: {e}")))?;
    host.note_written(written);
    Ok(())
}

/// The curves of a round's tests on one chart.
fn curves_chart(title: &str, tests: &[TestResult]) -> LineChart {
    let mut c = LineChart::new(title, "axial strain", "axial stress (Pa)");
    for t in tests {
        let x: Vec<f64> = t.curve.iter().map(|p| p.strain).collect();
        let y: Vec<f64> = t.curve.iter().map(|p| p.stress).collect();
        c.add_series(t.test.name(), x, y);
    }
    c
}

/// (file key, axis label, target, how to read the property).
type PropertyChart = (&'static str, &'static str, f64, fn(&MacroProperties) -> f64);

fn write_training(host: &Host, t: &Training, out: &str) -> RhaiResult<(Table, PathBuf)> {
    let table = rounds_table(t);
    let csv = host.out_path(&format!("{out}/rounds.csv"))?;
    write_atomic(&csv, table.0.borrow().to_csv().as_bytes())
        .map_err(|e| err(format!("cannot write {}: {e}", csv.display())))?;
    host.note_written([csv]);
    let rounds: Vec<f64> = t.rounds.iter().map(|r| r.round as f64).collect();
    let tg = &t.targets;
    let props: [PropertyChart; 5] = [
        ("E", "Young's modulus E (Pa)", tg.young, |p| p.young),
        ("nu", "Poisson's ratio ν", tg.poisson, |p| p.poisson),
        ("Tu", "tensile strength Tu (Pa)", tg.tensile, |p| p.tensile),
        ("Cu", "compressive strength Cu (Pa)", tg.compressive, |p| p.compressive),
        ("mu_i", "internal friction μi", tg.internal_friction, |p| p.internal_friction),
    ];
    for (key, label, target, get) in props {
        let mut c = LineChart::new(format!("{}: {label}, target vs measured", t.name), "round", label);
        c.add_series("target", rounds.clone(), vec![target; rounds.len()]);
        c.add_series("measured", rounds.clone(), t.rounds.iter().map(|r| get(&r.measured)).collect::<Vec<_>>());
        save_chart(host, &c, &format!("{out}/{key}"))?;
    }
    let best = t.best_round();
    save_chart(
        host,
        &curves_chart(&format!("{}: tests of round {} (closest)", t.name, best.round), &best.tests),
        &format!("{out}/stress_strain"),
    )?;
    let file = host.out_path(&format!("materials/{}.ron", t.name))?;
    let text = ron::ser::to_string_pretty(&t.trained_material(), ron::ser::PrettyConfig::default())
        .map_err(|e| err(format!("cannot encode the material: {e}")))?;
    write_atomic(&file, text.as_bytes()).map_err(|e| err(format!("cannot write {}: {e}", file.display())))?;
    host.note_written([file.clone()]);
    Ok((table, file))
}

fn train_fn(host: &Host, targets_map: Map, opts_map: Map) -> RhaiResult<Map> {
    let (name, t, density) = targets(&targets_map, dimension(&opts_map, "train options")?)?;
    let opts = options(&opts_map, density)?;
    let quiet = opts_map.get("quiet").and_then(|v| v.as_bool().ok()).unwrap_or(false);
    let out = opts_map.get("out").map(|v| v.to_string()).unwrap_or_else(|| format!("train_{name}"));
    host.out_path(&out)?;
    let mut on_round = |r: &Round| {
        if !quiet {
            outln!("{}", crate::terminal_text::lines(&round_line(&name, r, &t)));
        }
    };
    let training = matdem_engine::training::train(&name, &t, &opts, &host.control, &mut on_round).map_err(raise)?;
    let (table, file) = write_training(host, &training, &out)?;
    let best = training.best_round();
    if !quiet {
        let verdict = if training.converged {
            format!("converged in round {}", best.round)
        } else {
            format!("did NOT converge in {} rounds; closest is round {}", training.rounds.len(), best.round)
        };
        outln!(
            "train {}: {verdict} ({} elements, d = {:.3e} m); saved {}",
            crate::terminal_text::one_line(&name),
            training.elements,
            training.diameter,
            file.display()
        );
    }
    let mut map = Map::new();
    map.insert("material".into(), Dynamic::from(best.material.clone()));
    map.insert("converged".into(), training.converged.into());
    map.insert("best_round".into(), (best.round as INT).into());
    map.insert("rounds".into(), Dynamic::from(table));
    map.insert("measured".into(), properties_map(&best.measured).into());
    map.insert("micro".into(), micro_map(&best.material).into());
    map.insert("elements".into(), (training.elements as INT).into());
    map.insert("d".into(), training.diameter.into());
    map.insert("packing_seconds".into(), training.packing_seconds.into());
    let per_round = training.rounds.iter().map(|r| r.wall_seconds).sum::<f64>() / training.rounds.len() as f64;
    map.insert("seconds_per_round".into(), per_round.into());
    map.insert("file".into(), file.display().to_string().into());
    Ok(map)
}

/// `load_material(name)` reads `materials/<name>.ron` (or `name` itself when it ends in
/// `.ron`) from the run's output folder, else from the script's folder.
fn load_trained(host: &Host, name: &str) -> RhaiResult<TrainedMaterial> {
    let rel = if name.ends_with(".ron") { name.to_string() } else { format!("materials/{name}.ron") };
    let missing = format!(
        "no trained material `{name}`; train it first (train(#{{ name: \"{name}\", ... }}, #{{}})) or copy its .ron \
         file beside the script as {rel}"
    );
    let (path, bytes) = host.read_input(&rel, &missing)?;
    let text = String::from_utf8(bytes).map_err(|e| err(format!("{path} is not text ({e})")))?;
    ron::from_str(&text)
        .map_err(|e| err(format!("{path} is not a trained material file ({e}); train it again with train(...)")))
}

fn lab_kind(kind: &str, opts: &Map) -> RhaiResult<LabTest> {
    match kind {
        "uniaxial_compression" => Ok(LabTest::UniaxialCompression),
        "uniaxial_tension" => Ok(LabTest::UniaxialTension),
        "confined_compression" => {
            let s3 = num(opts, "confining", "lab_test")?
                .ok_or_else(|| err("lab_test(\"confined_compression\"): give opts.confining, the σ3 in Pa"))?;
            Ok(LabTest::ConfinedCompression { confining: s3 })
        }
        other => Err(raise(matdem_engine::Error::unknown(
            "lab test",
            other,
            &["uniaxial_compression", "uniaxial_tension", "confined_compression"],
        ))),
    }
}

fn test_sample(host: &Host, material: Material, opts: Map) -> RhaiResult<TestSample> {
    check_keys(&opts, SAMPLE_KEYS, "test_sample")?;
    let spec = sample_spec(&opts, "test_sample")?;
    let packed = PackedSample::pack(&spec, &material, &host.control).map_err(raise)?;
    let bonded = packed.bonded(&material, &host.control).map_err(raise)?;
    let (diameter, dimension) = (packed.diameter(), spec.dimension);
    Ok(TestSample(Rc::new(SampleData { diameter, material, bonded, dimension })))
}

fn lab_test(host: &Host, s: &TestSample, kind: &str, opts: Map) -> RhaiResult<Map> {
    check_keys(&opts, LAB_KEYS, "lab_test")?;
    let test = lab_kind(kind, &opts)?;
    let lattice = s.0.dimension.lattice_macro(&s.0.material, s.0.diameter);
    let expected = match num(&opts, "expected_peak_strain", "lab_test")? {
        Some(e) => e,
        None => match test {
            LabTest::UniaxialTension => lattice.tensile / lattice.young,
            LabTest::UniaxialCompression => lattice.compressive / lattice.young,
            LabTest::ConfinedCompression { confining } => {
                let n = ((1.0 + lattice.internal_friction.powi(2)).sqrt() + lattice.internal_friction).powi(2);
                (lattice.compressive + (n - 1.0) * confining) / lattice.young
            }
        },
    };
    let steps_to_peak = num(&opts, "steps_to_peak", "lab_test")?.unwrap_or(TrainOptions::default().steps_to_peak);
    let r = run_test(&s.0.bonded, test, &Loading::reaching_peak_in(steps_to_peak, expected), &host.control)
        .map_err(raise)?;
    let curve = Table::default();
    for p in &r.curve {
        curve.0.borrow_mut().push(&[
            ("strain".to_string(), p.strain),
            ("stress".to_string(), p.stress),
            ("grain_strain".to_string(), p.grain_strain),
            ("lateral_strain".to_string(), p.lateral_strain),
            ("broken_bonds".to_string(), p.broken_bonds as f64),
        ]);
    }
    let mut map = Map::new();
    map.insert("peak_stress".into(), r.peak_stress.into());
    map.insert("peak_strain".into(), r.peak_strain.into());
    map.insert("E".into(), r.young.into());
    map.insert("nu".into(), r.poisson.into());
    map.insert("peaked".into(), r.peaked.into());
    map.insert("steps".into(), (r.steps as INT).into());
    map.insert("strain_per_step".into(), (expected / steps_to_peak).into());
    map.insert("curve".into(), Dynamic::from(curve));
    Ok(map)
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<TestSample>("TestSample");
    let h = host.clone();
    engine.register_fn("train", move |t: Map, o: Map| train_fn(&h, t, o));
    let h = host.clone();
    engine.register_fn("load_material", move |name: &str| -> RhaiResult<Material> {
        Ok(load_trained(&h, name)?.material())
    });
    let h = host.clone();
    engine.register_fn("load_material", move |name: &str, d: FLOAT| -> RhaiResult<Material> {
        load_trained(&h, name)?.for_diameter(d).map_err(raise)
    });
    let h = host.clone();
    engine
        .register_fn("trained_diameter", move |name: &str| -> RhaiResult<f64> { Ok(load_trained(&h, name)?.diameter) });
    engine.register_fn("rescaled", |m: &mut Material, d_old: FLOAT, d_new: FLOAT| -> RhaiResult<Material> {
        m.rescaled(d_old, d_new).map_err(raise)
    });
    let h = host.clone();
    engine.register_fn("test_sample", move |m: Material, opts: Map| test_sample(&h, m, opts));
    engine
        .register_get("elements", |s: &mut TestSample| s.0.bonded.len() as INT)
        .register_get("d", |s: &mut TestSample| s.0.diameter)
        .register_get("bonds", |s: &mut TestSample| s.0.bonded.bond_count() as INT)
        .register_fn("to_string", |s: &mut TestSample| {
            format!(
                "TestSample of `{}`: {} elements, d = {:.3e} m, {} bonds",
                s.0.material.name,
                s.0.bonded.len(),
                s.0.diameter,
                s.0.bonded.bond_count()
            )
        });
    let h = host;
    engine.register_fn("lab_test", move |s: &mut TestSample, kind: &str, opts: Map| lab_test(&h, s, kind, opts));
    engine.register_fn("mohr_coulomb", |s3: Array, s1: Array| -> RhaiResult<Map> {
        let s3 = to_numbers(&Dynamic::from_array(s3), "σ3")?;
        let s1 = to_numbers(&Dynamic::from_array(s1), "σ1")?;
        if s3.len() != s1.len() {
            return Err(err("mohr_coulomb: give as many σ1 peaks as σ3 values"));
        }
        let pts: Vec<(f64, f64)> = s3.into_iter().zip(s1).collect();
        let mc = mohr_coulomb(&pts).ok_or_else(|| {
            err("mohr_coulomb: needs two or more different σ3 and σ1 rising with σ3 (no friction angle otherwise)")
        })?;
        let mut map = Map::new();
        map.insert("mu_i".into(), mc.internal_friction.into());
        map.insert("cohesion".into(), mc.cohesion.into());
        map.insert("slope".into(), mc.slope.into());
        map.insert("intercept".into(), mc.intercept.into());
        Ok(map)
    });
}
