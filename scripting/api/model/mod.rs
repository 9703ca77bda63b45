//! The model `d` as scripts see it (MatDEM: `d = B.d`): whole-array state, groups,
//! materials, boundaries, balance and records.
//!
//! One file per concept: `lanes` (whole arrays), `settings` (time step, gravity, damping,
//! laws, effects), `groups` (groups, materials, fixities, bonds), `boundaries` (walls and
//! servos), `running` (run and balance, journaled for resume), `observation` (records,
//! energies, porosity), `elements` (MatDEM's model surgery: delete, add, move, freeze) and
//! `regions` (masks from geometry, layers), `fields` (temperature, heat conduction, the
//! water table), `moisture` (water content, evaporation, drying shrinkage), `pores`
//! (pore density flow), `loads` (applied forces and torques, rotation angles) and `confinement`
//! (a triaxial cell's confining pressure).

/// A query of the model's evolving state, journaled (see `Host::observe`): a resumed run
/// replays the script with these answers. `$body` may use `?`.
macro_rules! observed {
    ($host:expr, $call:literal, |$d:ident $(, $a:ident : $t:ty)*| $body:expr) => {{
        let h = $host.clone();
        move |$d: &mut ModelHandle $(, $a: $t)*| -> RhaiResult<Dynamic> {
            h.observe($call, || Ok(Dynamic::from($body)))
        }
    }};
}

mod boundaries;
mod clumps;
mod confinement;
pub mod contacts;
pub mod cutting;
mod elements;
pub mod fabric;
mod fields;
mod groups;
mod lanes;
mod loads;
pub mod measure;
mod moisture;
mod observation;
mod periodic;
mod planar;
mod pores;
mod regions;
mod settings;
mod stepping;

use super::arrays::{number, to_numbers, Field, Mask};
use super::table::{row_from_map, Table, TableData};
use super::{err, raise, resume_point, Host, RhaiResult};
use crate::resume::SavedBalance;
use crate::stop::Stop;
use matdem_engine::backend::Target;
use matdem_engine::simulation::Balance;
use matdem_engine::state::particles::dof;
use matdem_engine::status::{porosity, Region};
use matdem_engine::{Material, Model, Simulation, Vec3, WallMotion};
use rhai::{Array, Dynamic, Engine, EvalAltResult, Map, FLOAT, INT};
use std::cell::{RefCell, RefMut};
use std::rc::Rc;

pub struct ModelData {
    pub name: String,
    pub sim: Simulation,
    pub status: Table,
    /// Creation number within the run (see [`Host::adopt`]).
    pub number: usize,
    /// The ParaView series `snapshot_every` set up (shared with the simulation's observer).
    pub snapshots: Rc<RefCell<super::snapshots::SnapshotLog>>,
    /// The movie `movie_every` started, if any (shared with the simulation's observer).
    pub movie: Rc<RefCell<crate::movie::Movie>>,
    /// Whether its plan was noted for the run page (and printed, in plan mode).
    plan_noted: bool,
}

/// A shared handle: every script variable that holds the model refers to the same model.
#[derive(Clone)]
pub struct ModelHandle(pub Rc<RefCell<ModelData>>);

impl ModelHandle {
    /// A handle for model number `number`, stepping on `target`; scripts get theirs through
    /// [`Host::adopt`].
    pub fn new(name: &str, model: Model, number: usize, target: Target) -> Self {
        let sim = Simulation::with_target(model, target);
        ModelHandle(Rc::new(RefCell::new(ModelData {
            name: name.to_string(),
            sim,
            status: Table::default(),
            number,
            snapshots: Rc::default(),
            movie: Rc::default(),
            plan_noted: false,
        })))
    }

    pub fn data(&self) -> RefMut<'_, ModelData> {
        self.0.borrow_mut()
    }

    fn model(&self) -> RefMut<'_, Model> {
        RefMut::map(self.0.borrow_mut(), |d| &mut d.sim.model)
    }
}

/// Puts the model's observers in place, each on its own period: its snapshot series
/// (`snapshot_every`) and its movie (`movie_every`), whichever are on.
pub fn install_observers(data: &mut ModelData) {
    use matdem_engine::simulation::Observer;
    let mut observers = Vec::new();
    let every = data.snapshots.borrow().every;
    if every > 0 {
        let log = data.snapshots.clone();
        observers.push(Observer { every, call: Box::new(move |m: &Model| super::snapshots::write_next(&log, m)) });
    }
    let movie_every = data.movie.borrow().state.settings.as_ref().map(|s| s.every);
    if let Some(every) = movie_every {
        let movie = data.movie.clone();
        observers.push(Observer { every, call: Box::new(move |m: &Model| movie.borrow_mut().capture(m)) });
    }
    data.sim.observers = observers;
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

/// Degrees of freedom from a script's letters: x, y, z translate; r before an axis rotates
/// about it ("rx", "ry", "rz"; "xyz rxryrz" fixes all six). Spaces and commas separate nothing.
fn dofs(s: &str) -> RhaiResult<u8> {
    let unknown = |c: char| {
        err(format!(
            "unknown degree of freedom `{c}` in \"{s}\": use x, y, z (translation) and rx, ry, rz (rotation), e.g. \
             \"xyz\" or \"ry\""
        ))
    };
    let (mut acc, mut rotation) = (0u8, false);
    for c in s.chars() {
        let axis = match c {
            ' ' | ',' if !rotation => continue,
            'r' | 'R' if !rotation => {
                rotation = true;
                continue;
            }
            'x' | 'X' => 0,
            'y' | 'Y' => 1,
            'z' | 'Z' => 2,
            _ => return Err(unknown(c)),
        };
        acc |= if rotation { [dof::RX, dof::RY, dof::RZ][axis] } else { [dof::X, dof::Y, dof::Z][axis] };
        rotation = false;
    }
    if rotation {
        return Err(err(format!("\"{s}\" ends with `r`: name the axis of the rotation, rx, ry or rz")));
    }
    Ok(acc)
}

fn positive(name: &str, v: f64) -> RhaiResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(err(format!("{name} must be a finite number > 0, got {v}")))
    }
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<ModelHandle>("Model");
    lanes::register(engine, &host);
    loads::register(engine, &host);
    settings::register(engine, &host);
    groups::register(engine, &host);
    boundaries::register(engine, &host);
    confinement::register(engine, &host);
    planar::register(engine);
    clumps::register(engine);
    periodic::register(engine);
    stepping::register(engine, &host);
    observation::register(engine, &host);
    elements::register(engine, &host);
    regions::register(engine, &host);
    fields::register(engine, &host);
    moisture::register(engine, &host);
    cutting::register(engine, &host);
    pores::register(engine, &host);
    contacts::register(engine, &host);
    fabric::register(engine, &host);
    measure::register(engine, &host);
}
