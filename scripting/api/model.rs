//! The model `d` as scripts see it (MatDEM: `d = B.d`): whole-array state, groups,
//! materials, boundaries, balance and records.

use super::field::{number, to_numbers, Field, Mask};
use super::table::{row_from_map, Table};
use super::{err, raise, Host, RhaiResult, PLAN_DONE};
use crate::resume::{self, SavedBalance, INTERRUPTED};
use matdem_engine::backend::gpu::device::GpuContext;
use matdem_engine::simulation::Balance;
use matdem_engine::state::particles::dof;
use matdem_engine::status::{porosity, Region};
use matdem_engine::{Material, Model, Simulation, Vec3, WallMotion};
use rhai::{Array, Dynamic, Engine, EvalAltResult, Map, FLOAT, INT};
use std::cell::{RefCell, RefMut};
use std::rc::Rc;
use std::sync::Arc;

pub struct ModelData {
    pub name: String,
    pub sim: Simulation,
    pub status: Table,
    /// Creation number within the run (see [`Host::adopt`]).
    pub number: usize,
    /// The ParaView series `snapshot_every` set up (shared with the simulation's observer).
    pub snapshots: Rc<RefCell<super::snapshots::SnapshotLog>>,
    plan_printed: bool,
}

/// A shared handle: every script variable that holds the model refers to the same model.
#[derive(Clone)]
pub struct ModelHandle(pub Rc<RefCell<ModelData>>);

impl ModelHandle {
    /// A handle for model number `number`, stepping on `gpu` when given, else on the CPU
    /// backend; scripts get theirs through [`Host::adopt`].
    pub fn new(name: &str, model: Model, number: usize, gpu: Option<Arc<GpuContext>>) -> Self {
        let sim = match gpu {
            Some(ctx) => Simulation::with_gpu(model, ctx),
            None => Simulation::new(model),
        };
        ModelHandle(Rc::new(RefCell::new(ModelData {
            name: name.to_string(),
            sim,
            status: Table::default(),
            number,
            snapshots: Rc::default(),
            plan_printed: false,
        })))
    }

    pub fn data(&self) -> RefMut<'_, ModelData> {
        self.0.borrow_mut()
    }

    fn model(&self) -> RefMut<'_, Model> {
        RefMut::map(self.0.borrow_mut(), |d| &mut d.sim.model)
    }
}

/// Particle ids named by a group, `"all"`, an array of ids or a mask.
pub fn resolve_ids(m: &Model, sel: &Dynamic) -> RhaiResult<Vec<u32>> {
    if let Some(name) = sel.clone().try_cast::<rhai::ImmutableString>() {
        if name == "all" {
            return Ok((0..m.len() as u32).collect());
        }
        return m.groups.get(&name).map(|g| g.to_vec()).map_err(raise);
    }
    if let Some(mask) = sel.clone().try_cast::<Mask>() {
        if mask.0.len() != m.len() {
            return Err(err(format!("mask has {} entries but the model has {} particles", mask.0.len(), m.len())));
        }
        return Ok(mask.0.iter().enumerate().filter(|(_, b)| **b).map(|(i, _)| i as u32).collect());
    }
    if let Some(a) = sel.clone().try_cast::<Array>() {
        let ids = a
            .iter()
            .map(|v| match v.as_int() {
                Ok(i) if i >= 0 => Ok(i as u32),
                _ => Err(err(format!("particle ids must be integers ≥ 0, got {v}"))),
            })
            .collect::<RhaiResult<Vec<u32>>>()?;
        m.check_ids(&ids).map_err(raise)?;
        return Ok(ids);
    }
    Err(err(format!("expected a group name, \"all\", an array of ids or a mask, got {}", sel.type_name())))
}

fn vec3(v: &Dynamic, what: &str) -> RhaiResult<Vec3> {
    let n = to_numbers(v, what)?;
    if n.len() != 3 || !n.iter().all(|x| x.is_finite()) {
        return Err(err(format!("{what}: expected [x, y, z] with 3 finite numbers")));
    }
    Ok(Vec3::new(n[0], n[1], n[2]))
}

fn dofs(s: &str) -> RhaiResult<u8> {
    s.chars().try_fold(0u8, |acc, c| match c {
        'x' | 'X' => Ok(acc | dof::X),
        'y' | 'Y' => Ok(acc | dof::Y),
        'z' | 'Z' => Ok(acc | dof::Z),
        _ => Err(err(format!("unknown degree of freedom `{c}` in \"{s}\": use a combination of x, y, z"))),
    })
}

fn lane(d: &ModelHandle, f: impl Fn(&Model, usize) -> f64) -> Field {
    let m = d.model();
    Field::new((0..m.len()).map(|i| f(&m, i)).collect())
}

fn positive(name: &str, v: f64) -> RhaiResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(err(format!("{name} must be a finite number > 0, got {v}")))
    }
}

/// Runs or balances the model (`call` names the script function), with progress and
/// cancellation; in plan mode prints the plan instead. Journaled like every observation: a
/// resumed run gives back what the call returned, and at the interrupted call restores the
/// models and runs the rest of its steps. Cancelled, it writes the resume folder and ends
/// the script.
fn run_steps(host: &Host, d: &ModelHandle, call: &str, how: Balance) -> RhaiResult<Dynamic> {
    if host.plan_only {
        let mut data = d.data();
        if !data.plan_printed {
            let plan = data.sim.plan().to_string();
            println!("model `{}` ({} particles):\n{plan}", data.name, data.sim.model.len());
            data.plan_printed = true;
        }
        return Err(err(PLAN_DONE));
    }
    let (how, done) = {
        let s = host.session.borrow();
        match &s.pending {
            Some(p) if s.cursor == p.interrupted.index => {
                drop(s);
                resume::restore(host, call)?
            }
            _ if s.replaying() => {
                drop(s);
                return host.observe(call, || unreachable_in_replay(call));
            }
            _ => {
                drop(s);
                // A standard balance becomes its step count now, so a resume runs the same count.
                let how = match how {
                    Balance::Standard { rounds } => {
                        Balance::Steps((d.data().sim.standard_balance_steps() as f64 * rounds).ceil() as u64)
                    }
                    other => other,
                };
                (how, 0)
            }
        }
    };
    let mut cancelled = None;
    let result = host.observe(call, || {
        let mut data = d.data();
        let total = match how {
            Balance::Steps(n) => n,
            Balance::Standard { rounds } => (data.sim.standard_balance_steps() as f64 * rounds).ceil() as u64,
            Balance::Tolerance { max_steps, .. } => max_steps,
        };
        let bar = (host.progress && total >= 2000).then(|| {
            let b = indicatif::ProgressBar::new(total);
            b.set_style(
                indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} steps, {per_sec}, {eta} left")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_message(format!("{}: balance", data.name));
            b.set_position(done);
            b
        });
        let mut progress = |k: u64| {
            if let Some(b) = &bar {
                b.set_position(k);
            }
        };
        let started = std::time::Instant::now();
        let rep = data.sim.balance_from(how, done, &host.control, &mut progress);
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        // Without a terminal there is no bar: a log still hears of each long balance.
        let secs = started.elapsed().as_secs_f64();
        if let (false, Ok(r)) = (host.progress, &rep) {
            if secs >= LOG_BALANCE_AFTER_S {
                let rate = r.steps as f64 * data.sim.model.len() as f64 / secs;
                eprintln!("{}: {call} of {} steps in {secs:.1} s ({rate:.3e} particle-steps/s)", data.name, r.steps);
            }
        }
        let rep = match rep {
            Err(matdem_engine::Error::Cancelled { completed_steps }) => {
                cancelled = Some(completed_steps);
                return Err(err(INTERRUPTED));
            }
            other => other.map_err(raise)?,
        };
        let mut map = Map::new();
        map.insert("steps".into(), (rep.steps as INT).into());
        if let Some(r) = rep.unbalanced_ratio {
            map.insert("unbalanced_ratio".into(), r.into());
        }
        Ok(Dynamic::from_map(map))
    });
    if let Some(completed) = cancelled {
        if !host.resumable {
            return Err(raise(matdem_engine::Error::Cancelled { completed_steps: completed }));
        }
        // The journal must end before this call: take back the entry `observe` made for it.
        host.session.borrow_mut().entries.pop();
        let saved = SavedBalance::from_balance(how).expect("standard balances were turned into steps above");
        let dir = resume::write_resume(host, call, saved, completed).map_err(err)?;
        let name = d.data().name.clone();
        eprintln!(
            "interrupted: `{name}` stopped after {completed} step(s) of its {call}; resume data in {}",
            dir.display()
        );
        return Err(Box::new(EvalAltResult::ErrorTerminated(INTERRUPTED.into(), rhai::Position::NONE)));
    }
    result
}

/// A balance that takes at least this long is logged when no progress bar is drawn.
const LOG_BALANCE_AFTER_S: f64 = 5.0;

/// A replayed run call never runs: `observe` answers it from the journal.
fn unreachable_in_replay(call: &str) -> RhaiResult<Dynamic> {
    Err(err(format!("internal error: `{call}` ran while replaying; please report this bug")))
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<ModelHandle>("Model");
    // A query of the model's evolving state, journaled (see `Host::observe`): a resumed run
    // replays the script with these answers. `$body` may use `?`.
    macro_rules! observed {
        ($call:literal, |$d:ident $(, $a:ident : $t:ty)*| $body:expr) => {{
            let h = host.clone();
            move |$d: &mut ModelHandle $(, $a: $t)*| -> RhaiResult<Dynamic> {
                h.observe($call, || Ok(Dynamic::from($body)))
            }
        }};
    }
    // Whole-array lanes (a sync point on the GPU later).
    macro_rules! lane_get {
        ($name:literal, $f:expr) => {
            engine.register_get($name, observed!($name, |d| lane(d, $f)));
        };
    }
    lane_get!("x", |m, i| m.particles.pos[i].x);
    lane_get!("y", |m, i| m.particles.pos[i].y);
    lane_get!("z", |m, i| m.particles.pos[i].z);
    lane_get!("r", |m, i| m.particles.radius[i]);
    lane_get!("vx", |m, i| m.particles.vel[i].x);
    lane_get!("vy", |m, i| m.particles.vel[i].y);
    lane_get!("vz", |m, i| m.particles.vel[i].z);
    lane_get!("fx", |m, i| m.particles.force[i].x);
    lane_get!("fy", |m, i| m.particles.force[i].y);
    lane_get!("fz", |m, i| m.particles.force[i].z);
    lane_get!("dx", |m, i| m.particles.pos[i].x - m.particles.origin[i].x);
    lane_get!("dy", |m, i| m.particles.pos[i].y - m.particles.origin[i].y);
    lane_get!("dz", |m, i| m.particles.pos[i].z - m.particles.origin[i].z);
    lane_get!("displacement", |m, i| (m.particles.pos[i] - m.particles.origin[i]).norm());
    lane_get!("mass", |m, i| m.particles.mass[i]);
    lane_get!("material", |m, i| m.particles.material[i] as f64);
    engine
        .register_get("contact_load", observed!("contact_load", |d| Field::new(d.data().sim.contact_loads())))
        .register_get("n", |d: &mut ModelHandle| d.model().len() as INT)
        .register_get("name", |d: &mut ModelHandle| d.data().name.clone())
        .register_get("time", observed!("time", |d| d.model().clock.time))
        .register_get("step", observed!("step", |d| d.model().clock.step as INT))
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
                other => Err(raise(matdem_engine::Error::unknown("effect", other, &["rotation"]))),
            }
        })
        .register_fn("plan", |d: &mut ModelHandle| d.data().sim.plan().to_string());

    // Groups.
    engine
        .register_fn("add_group", |d: &mut ModelHandle, name: &str, sel: Dynamic| -> RhaiResult<INT> {
            let mut m = d.model();
            let ids = resolve_ids(&m, &sel)?;
            let n = ids.len();
            m.groups.set(name, ids);
            Ok(n as INT)
        })
        .register_fn("group_where", |d: &mut ModelHandle, name: &str, mask: Mask| -> RhaiResult<INT> {
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
            Ok(Mask(Rc::new(mask)))
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
            observed!("connect", |d, sel: Dynamic, tol: FLOAT| {
                let mut m = d.model();
                let ids = resolve_ids(&m, &sel)?;
                m.connect(Some(&ids), tol).map_err(raise)? as INT
            }),
        )
        .register_fn(
            "break_bonds",
            observed!("break_bonds", |d, sel: Dynamic| {
                let mut m = d.model();
                let ids = resolve_ids(&m, &sel)?;
                m.break_bonds(Some(&ids)).map_err(raise)? as INT
            }),
        )
        .register_get("bonds", observed!("bonds", |d| d.model().bond_count() as INT))
        .register_get("broken_bonds", observed!("broken_bonds", |d| d.model().breakages.len() as INT));

    // Boundaries.
    engine
        .register_fn("move_boundary", |d: &mut ModelHandle, name: &str, v: Array| -> RhaiResult<()> {
            let v = vec3(&Dynamic::from_array(v), "boundary velocity")?;
            d.model().wall_mut(name).map_err(raise)?.motion = WallMotion::Velocity(v);
            Ok(())
        })
        .register_fn("place_boundary", |d: &mut ModelHandle, name: &str, to: Array| -> RhaiResult<()> {
            let to = vec3(&Dynamic::from_array(to), "boundary position")?;
            let mut m = d.model();
            let w = m.wall_mut(name).map_err(raise)?;
            match &mut w.shape {
                matdem_engine::WallShape::Plane { point, .. } => *point = to,
                matdem_engine::WallShape::Cylinder { .. } => {
                    return Err(err(format!("place_boundary: `{name}` is a ring; only planes can be placed")))
                }
            }
            Ok(())
        })
        .register_fn("stop_boundary", |d: &mut ModelHandle, name: &str| -> RhaiResult<()> {
            d.model().wall_mut(name).map_err(raise)?.motion = WallMotion::Fixed;
            Ok(())
        })
        .register_fn("set_boundary_friction", |d: &mut ModelHandle, name: &str, mu: FLOAT| -> RhaiResult<()> {
            if !(mu.is_finite() && mu >= 0.0) {
                return Err(err(format!("friction must be ≥ 0, got {mu}")));
            }
            d.model().wall_mut(name).map_err(raise)?.friction = Some(mu);
            Ok(())
        })
        .register_fn("set_platen_stress", |d: &mut ModelHandle, name: &str, stress: FLOAT| -> RhaiResult<()> {
            set_servo(d, name, stress, None)
        })
        .register_fn("set_platen_stress", |d: &mut ModelHandle, name: &str, stress: FLOAT, max_speed: FLOAT| {
            set_servo(d, name, stress, Some(max_speed))
        })
        .register_fn(
            "boundary",
            observed!("boundary", |d, name: &str| {
                let m = d.model();
                let w = &m.walls[m.wall_index(name).map_err(raise)?];
                let mut map = Map::new();
                let v3 = |v: Vec3| vec![Dynamic::from_float(v.x), Dynamic::from_float(v.y), Dynamic::from_float(v.z)];
                map.insert("stress".into(), w.stress().into());
                map.insert("force".into(), v3(w.force).into());
                map.insert("displacement".into(), v3(w.displacement).into());
                map.insert("contacts".into(), (w.contacts as INT).into());
                let pos = match &w.shape {
                    matdem_engine::WallShape::Plane { point, .. } => v3(*point),
                    matdem_engine::WallShape::Cylinder { radius, .. } => vec![Dynamic::from_float(*radius)],
                };
                map.insert("position".into(), pos.into());
                map
            }),
        )
        .register_get("boundaries", |d: &mut ModelHandle| {
            d.model().walls.iter().map(|w| Dynamic::from(w.name.clone())).collect::<Array>()
        });

    // Running.
    let h = host.clone();
    engine.register_fn("run", move |d: &mut ModelHandle, steps: INT| {
        if steps < 0 {
            return Err(err(format!("steps must be ≥ 0, got {steps}")));
        }
        run_steps(&h, d, "run", Balance::Steps(steps as u64))
    });
    let h = host.clone();
    engine.register_fn("balance", move |d: &mut ModelHandle| {
        run_steps(&h, d, "balance", Balance::Standard { rounds: 1.0 })
    });
    let h = host.clone();
    engine.register_fn("balance", move |d: &mut ModelHandle, how: Dynamic| {
        let mode = balance_mode(&how, 1.0)?;
        run_steps(&h, d, "balance", mode)
    });
    let h = host.clone();
    engine.register_fn("balance", move |d: &mut ModelHandle, how: &str, rounds: Dynamic| {
        let rounds = number(&rounds).ok_or_else(|| err("balance: rounds must be a number"))?;
        let mode = balance_mode(&Dynamic::from(how.to_string()), rounds)?;
        run_steps(&h, d, "balance", mode)
    });
    let h = host.clone();
    engine.register_fn("balance_until", move |d: &mut ModelHandle, ratio: FLOAT, max_steps: INT| {
        positive("ratio", ratio)?;
        if max_steps <= 0 {
            return Err(err("balance_until: max_steps must be > 0"));
        }
        run_steps(&h, d, "balance_until", Balance::Tolerance { ratio, max_steps: max_steps as u64 })
    });

    // Observation.
    engine
        .register_fn("record", {
            let h = host.clone();
            move |d: &mut ModelHandle| {
                push_recorded(d, h.observe("record", || record(d, &Map::new()).map(Dynamic::from))?)
            }
        })
        .register_fn("record", {
            let h = host.clone();
            move |d: &mut ModelHandle, extra: Map| {
                push_recorded(d, h.observe("record", || record(d, &extra).map(Dynamic::from))?)
            }
        })
        .register_get("status", |d: &mut ModelHandle| d.data().status.clone())
        .register_fn(
            "energies",
            observed!("energies", |d| {
                let e = d.data().sim.energies();
                let mut map = Map::new();
                for (k, v) in [
                    ("kinetic", e.kinetic),
                    ("normal_elastic", e.normal_elastic),
                    ("shear_elastic", e.shear_elastic),
                    ("gravity", e.gravity),
                    ("heat_damping", e.heat_damping),
                    ("heat_contact_damping", e.heat_contact_damping),
                    ("heat_friction", e.heat_friction),
                    ("heat_breakage", e.heat_breakage),
                    ("wall_work", e.wall_work),
                    ("total", e.total()),
                ] {
                    map.insert(k.into(), v.into());
                }
                map
            }),
        )
        .register_fn(
            "coordination_number",
            observed!("coordination_number", |d| d.data().sim.contact_stats().coordination),
        )
        .register_fn(
            "mean_contact_force",
            observed!("mean_contact_force", |d| d.data().sim.contact_stats().mean_normal_force),
        )
        .register_fn(
            "unbalanced_ratio",
            observed!("unbalanced_ratio", |d| d.data().sim.contact_stats().unbalanced_ratio),
        )
        .register_fn(
            "porosity_cylinder",
            observed!("porosity_cylinder", |d, radius: FLOAT, z0: FLOAT, z1: FLOAT| {
                if !(radius.is_finite() && radius > 0.0 && z0.is_finite() && z1.is_finite() && z0 < z1) {
                    return Err(err(format!(
                        "porosity_cylinder: the window must have a radius > 0 and z0 < z1 (finite, m), \
                         got radius {radius}, z0 {z0}, z1 {z1}; give the lower height first"
                    )));
                }
                porosity(&d.model(), &Region::Cylinder { center: Vec3::zeros(), radius, z0, z1 })
            }),
        )
        .register_fn(
            "porosity_box",
            observed!("porosity_box", |d, lo: Array, hi: Array| {
                let (lo, hi) = (vec3(&Dynamic::from_array(lo), "lo")?, vec3(&Dynamic::from_array(hi), "hi")?);
                if let Some(k) = (0..3).find(|&k| lo[k] >= hi[k]) {
                    let axis = ["x", "y", "z"][k];
                    return Err(err(format!(
                        "porosity_box: the window is empty or inverted along {axis} (lo {} ≥ hi {}); \
                         give the lower corner first: porosity_box([x0, y0, z0], [x1, y1, z1]) with x0 < x1, y0 < y1, z0 < z1",
                        lo[k], hi[k]
                    )));
                }
                porosity(&d.model(), &Region::Box { lo, hi })
            }),
        )
        .register_fn(
            "to_string",
            observed!("to_string", |d| {
                let data = d.data();
                let m = &data.sim.model;
                format!(
                    "Model `{}`: {} particles, {} walls, step {}, t = {:.4e} s, dt = {:.3e} s",
                    data.name,
                    m.len(),
                    m.walls.len(),
                    m.clock.step,
                    m.clock.time,
                    m.clock.dt
                )
            }),
        );
}

fn set_servo(d: &ModelHandle, name: &str, stress: f64, max_speed: Option<f64>) -> RhaiResult<()> {
    if !(stress.is_finite() && stress >= 0.0) {
        return Err(err(format!("platen stress must be a finite number ≥ 0 Pa, got {stress}")));
    }
    let mut m = d.model();
    let dt = m.clock.dt;
    if dt <= 0.0 {
        return Err(err("set the time step first (set_standard_dt) so the servo can choose its speed"));
    }
    // Default speed limit: 0.2% of the mean radius per step keeps the platen quasi-static.
    let max_speed = match max_speed {
        Some(v) => positive("max_speed", v)?,
        None => 2e-3 * m.mean_radius() / dt,
    };
    m.wall_mut(name).map_err(raise)?.motion = WallMotion::Servo { stress, max_speed };
    Ok(())
}

fn balance_mode(how: &Dynamic, rounds: f64) -> RhaiResult<Balance> {
    if let Ok(n) = how.as_int() {
        if n < 0 {
            return Err(err(format!("balance: steps must be ≥ 0, got {n}")));
        }
        return Ok(Balance::Steps(n as u64));
    }
    match how.clone().try_cast::<rhai::ImmutableString>().as_deref() {
        Some("standard") | Some("Standard") => {
            positive("rounds", rounds)?;
            Ok(Balance::Standard { rounds })
        }
        Some(other) => Err(raise(matdem_engine::Error::unknown("balance mode", other, &["standard"]))),
        None => Err(err(format!("balance: expected \"standard\" or a number of steps, got {}", how.type_name()))),
    }
}

/// Appends a row to `d.status`: the standard quantities plus the script's own. Returns the
/// row as `[name, value]` pairs (in column order) for the journal; a replay appends the
/// journaled row instead (see [`push_recorded`]).
fn record(d: &ModelHandle, extra: &Map) -> RhaiResult<Array> {
    let extra = row_from_map(extra)?;
    let mut data = d.data();
    let stats = data.sim.contact_stats();
    let e = data.sim.energies();
    let m = &data.sim.model;
    let mut row = vec![
        ("step".to_string(), m.clock.step as f64),
        ("time".to_string(), m.clock.time),
        ("kinetic_energy".to_string(), e.kinetic),
        ("elastic_energy".to_string(), e.normal_elastic + e.shear_elastic),
        ("heat".to_string(), e.heat()),
        ("coordination".to_string(), stats.coordination),
        ("mean_contact_force".to_string(), stats.mean_normal_force),
        ("unbalanced_ratio".to_string(), stats.unbalanced_ratio),
        ("bonds".to_string(), stats.bonds as f64),
        ("broken_bonds".to_string(), m.breakages.len() as f64),
    ];
    for w in &m.walls {
        row.push((format!("{}_stress", w.name), w.stress()));
    }
    row.extend(extra);
    Ok(row.into_iter().map(|(k, v)| Dynamic::from_array(vec![k.into(), v.into()])).collect())
}

/// Appends a row given as `[name, value]` pairs to `d.status`.
fn push_recorded(d: &ModelHandle, row: Dynamic) -> RhaiResult<()> {
    let pairs = row.try_cast::<Array>().ok_or_else(|| err("internal error: a record row is not an array"))?;
    let row = pairs
        .into_iter()
        .map(|p| {
            let p = p.try_cast::<Array>().unwrap_or_default();
            match (p.first().and_then(|k| k.clone().into_string().ok()), p.get(1).and_then(|v| v.as_float().ok())) {
                (Some(k), Some(v)) => Ok((k, v)),
                _ => Err(err("internal error: a record row entry is not [name, value]")),
            }
        })
        .collect::<RhaiResult<Vec<_>>>()?;
    d.data().status.0.borrow_mut().push(&row);
    Ok(())
}
