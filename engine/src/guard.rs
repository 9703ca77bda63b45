//! The stability guard: cheap periodic checks that stop a run before it produces NaNs, with
//! a message naming the particle, the critical time step and the fix.
//!
//! Before a run: every length within a plausible range, dt against the stiffest element's
//! critical step, gravity against the smallest radius, the speeds a script set and each
//! applied load against what one step allows. At every chunk end (`guard_every` steps, both
//! backends): non-finite state, runaway speeds, deep overlaps, and dt against the critical
//! step of the stiffest current contact — Hertz's tangent stiffness at its overlap, a bond or
//! shear spring, a wall contact — so that a step too long for the loaded sample stops (or
//! warns once) with the contact named, instead of finishing with wrong physics.

use crate::effects::periodic::Separations;
use crate::error::{Error, Instability, Result, Suggestion};
use crate::model::Model;
use crate::physics::contact_law::PairParams;
use crate::physics::timestep::critical_step;
use crate::plan::StepPlan;
pub use crate::settings::guard::GuardMode;
use crate::state::particles::dof;
use crate::walls::WallMotion;

/// Refuses a time step above the critical step of the stiffest element.
pub fn check_time_step(m: &Model) -> Result<()> {
    let dt = m.clock.dt;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::InvalidScene(
            "the time step is not set: call set_standard_dt() or set dt to a positive value".into(),
        ));
    }
    // The lengths first: a radius of 1e-300 m has a critical step of zero, and the step is not
    // the cause.
    check_extent(m)?;
    if let Some((i, crit)) = m.critical_dt() {
        if dt > crit {
            return Err(unstable(
                m,
                i,
                format!("(the stiffest element) cannot be integrated: dt is {:.1}× its critical step", dt / crit),
            ));
        }
    }
    check_gravity(m)?;
    check_speeds(m)?;
    check_applied_loads(m)?;
    crate::plan::check_stages(m)
}

/// Refuses an element whose centre lies beyond [`MAX_LENGTH`] of the origin, whose radius
/// lies outside [`MIN_RADIUS`]..=[`MAX_LENGTH`], or whose mass is not a positive finite
/// number, naming the element and the value.
pub fn check_extent(m: &Model) -> Result<()> {
    let p = &m.particles;
    for i in 0..p.len() {
        let (x, r, mass) = (p.pos[i], p.radius[i], p.mass[i]);
        if let Some(c) = (0..3).find(|&c| !(-MAX_LENGTH..=MAX_LENGTH).contains(&x[c])) {
            return Err(Error::InvalidScene(format!(
                "element {i} lies at {} = {:e} m: a scene's centres stay within ±{MAX_LENGTH:e} m of the origin (a \
                 larger value is a unit or typing error, and past it the contact arithmetic overflows). Fix: place \
                 it inside the scene (d.{}, d.set, d.move_group) or remove it (d.delete)",
                ["x", "y", "z"][c],
                x[c],
                ["x", "y", "z"][c],
            )));
        }
        if !(MIN_RADIUS..=MAX_LENGTH).contains(&r) {
            return Err(Error::InvalidScene(format!(
                "element {i} has radius {r:e} m: a radius lies between {MIN_RADIUS:e} and {MAX_LENGTH:e} m (outside is \
                 a unit or typing error: no grain is smaller than a nanometre, and past either end its mass or its \
                 contacts' arithmetic leave the numbers). Fix: set its radius in metres (d.r, d.set(\"r\", …))",
            )));
        }
        if !(mass.is_finite() && mass > 0.0) {
            let material = &m.materials[p.material[i] as usize];
            return Err(Error::InvalidScene(format!(
                "element {i} (radius {r:e} m, material `{}` of density {:e} kg/m³) has mass {mass:e} kg, not a \
                 positive finite number. Fix: give the material a density in kg/m³ (2,650 for quartz)",
                material.name, material.density,
            )));
        }
    }
    Ok(())
}

/// Refuses an element or a wall that already moves further in one step than the guard lets
/// any element move ([`RUNAWAY_STEP_FRACTION`] of a radius): the guard would stop the run at
/// its first check, after the contacts it passed through had thrown it further; the cause is
/// the speed a script set, and the message says so.
pub fn check_speeds(m: &Model) -> Result<()> {
    let (p, dt) = (&m.particles, m.clock.dt);
    for i in 0..p.len() {
        let (v, r) = (p.vel[i].norm(), p.radius[i]);
        if v * dt > RUNAWAY_STEP_FRACTION * r {
            return Err(Error::InvalidScene(format!(
                "element {i} moves at {v:.3e} m/s, {:.0}% of its radius ({r:.3e} m) in one step of dt = {dt:.3e} s, \
                 where the guard stops any element at {:.0}%: it would pass through its contacts. Fix: give it a \
                 speed under {:.3e} m/s (d.vx, d.set_velocity), or a smaller dt",
                100.0 * v * dt / r,
                100.0 * RUNAWAY_STEP_FRACTION,
                RUNAWAY_STEP_FRACTION * r / dt,
            )));
        }
    }
    let smallest = (0..p.len()).filter(|&i| p.fixed[i] & dof::ALL != dof::ALL).map(|i| p.radius[i]).reduce(f64::min);
    let Some(r) = smallest else { return Ok(()) };
    for w in &m.walls {
        let (speed, what) = match w.motion {
            WallMotion::Fixed => continue,
            WallMotion::Velocity(v) => (v.norm(), "moves at"),
            WallMotion::Servo { max_speed, .. } => (max_speed.abs(), "may move (its servo's max_speed) at"),
        };
        if !(0.0..=RUNAWAY_STEP_FRACTION * r).contains(&(speed * dt)) {
            return Err(Error::InvalidScene(format!(
                "wall `{}` {what} {speed:.3e} m/s, {:.0}% of the smallest free radius ({r:.3e} m) in one step of \
                 dt = {dt:.3e} s, where the guard stops any element at {:.0}%: it would pass through the grains. Fix: \
                 move it slower than {:.3e} m/s (d.move_boundary, d.set_platen_stress), or take a smaller dt",
                w.name,
                100.0 * speed * dt / r,
                100.0 * RUNAWAY_STEP_FRACTION,
                RUNAWAY_STEP_FRACTION * r / dt,
            )));
        }
    }
    Ok(())
}

/// Refuses an applied load (`d.apply_force`, `d.apply_torque`) that alone moves its element,
/// from rest, further in one step than the guard lets any element move
/// ([`RUNAWAY_STEP_FRACTION`] of its radius): the guard would stop the run a step later on a
/// runaway or non-finite element and blame dt, where the cause is the load's value. A load the
/// grains can carry is far below this (held by contacts, it would press them past the guard's
/// overlap first), so the check refuses only what the guard would stop anyway.
pub fn check_applied_loads(m: &Model) -> Result<()> {
    let (p, dt) = (&m.particles, m.clock.dt);
    let a = &p.applied;
    if !a.allocated(m.len()) {
        return Ok(());
    }
    for i in 0..m.len() {
        let r = p.radius[i];
        let limit = RUNAWAY_STEP_FRACTION * r;
        let force = a.force[i].norm();
        let travel = force / p.mass[i] * dt * dt;
        if p.fixed[i] & dof::ALL != dof::ALL && travel > limit {
            return Err(runaway_load(i, ["force", "N", "d.apply_force"], force, travel, r, dt));
        }
        // A torque's turn in one step, as the travel of the element's surface.
        let torque = a.torque[i].norm();
        let turn = torque / p.inertia(i) * dt * dt * r;
        if p.fixed[i] & dof::ROTATION != dof::ROTATION && turn > limit {
            return Err(runaway_load(i, ["torque", "N·m", "d.apply_torque"], torque, turn, r, dt));
        }
    }
    Ok(())
}

/// The refusal of an applied load (`[what, unit, call]`, e.g. a force in N set by
/// `d.apply_force`) of `load` that alone moves element `i` of radius `r` by `travel` in a step.
fn runaway_load(i: usize, [what, unit, call]: [&str; 3], load: f64, travel: f64, r: f64, dt: f64) -> Error {
    let most = load * RUNAWAY_STEP_FRACTION * r / travel;
    Error::InvalidScene(format!(
        "the applied {what} is the cause: element {i} carries {load:.3e} {unit}, which alone moves it \
         {travel:.3e} m in one step of dt = {dt:.3e} s, {:.0}% of its radius ({r:.3e} m), where the guard stops \
         any element at {:.0}%, so the run would fly apart whatever the contacts. At this dt a {what} on it must \
         stay under {most:.3e} {unit}, and a load the grains can carry is far below that. Fix: give element {i} a \
         smaller {what} ({call}); a smaller dt only moves the limit (4× at dt/2)",
        100.0 * travel / r,
        100.0 * RUNAWAY_STEP_FRACTION,
    ))
}

/// Refuses elements that sit at exactly the same place (a geometry or group added twice):
/// their contact has no normal, and the run would stop later on a non-finite position that
/// names no cause. Sorted by position, so equal centres are neighbours: O(n log n), run when a
/// changed model is prepared, not every chunk.
pub fn check_coincident(m: &Model) -> Result<()> {
    let pos = &m.particles.pos;
    let mut order: Vec<usize> = (0..pos.len()).collect();
    let key = |i: usize| (pos[i].x, pos[i].y, pos[i].z);
    order.sort_unstable_by(|&a, &b| {
        let (ka, kb) = (key(a), key(b));
        ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1)).then(ka.2.total_cmp(&kb.2))
    });
    for w in order.windows(2) {
        let (i, j) = (w[0].min(w[1]), w[0].max(w[1]));
        if pos[i] == pos[j] {
            return Err(Error::InvalidScene(format!(
                "elements {i} and {j} sit at the same place ({:.6e}, {:.6e}, {:.6e}) m: a geometry or group added \
                 twice? Delete one copy (d.delete) before running",
                pos[i].x, pos[i].y, pos[i].z
            )));
        }
    }
    Ok(())
}

/// Refuses a gravity that by itself moves a free particle more than
/// [`GRAVITY_STEP_FRACTION`] of its radius further each step: the cause is gravity's value,
/// not dt, and the message says so.
pub fn check_gravity(m: &Model) -> Result<()> {
    let g = m.settings.gravity.norm();
    let dt = m.clock.dt;
    let p = &m.particles;
    let smallest = (0..p.len())
        .filter(|&i| p.fixed[i] & dof::ALL != dof::ALL)
        .min_by(|&a, &b| p.radius[a].total_cmp(&p.radius[b]));
    let Some(i) = smallest else { return Ok(()) };
    let r = p.radius[i];
    if g * dt * dt > GRAVITY_STEP_FRACTION * r {
        let sensible = GRAVITY_STEP_FRACTION * r / (dt * dt);
        return Err(Error::InvalidScene(format!(
            "gravity is the cause: |g| = {g:.3e} m/s² moves a free particle |g|·dt² = {:.3e} m further every step, \
             {:.0}% of the smallest radius ({r:.3e} m, particle {i}), so the run would fly apart whatever the contacts. \
             A sensible gravity is 9.81 m/s² (up to a few hundred for an accelerated deposition); at this dt \
             ({dt:.3e} s) it must stay under {sensible:.3e} m/s². Fix: set d.gravity to a sensible value; \
             halving dt is not the fix",
            g * dt * dt,
            100.0 * g * dt * dt / r,
        )));
    }
    Ok(())
}

/// Non-finite state, runaway speeds and deep overlaps.
pub fn check_state(m: &Model) -> Result<()> {
    let p = &m.particles;
    let dt = m.clock.dt;
    for i in 0..p.len() {
        let (x, v, f) = (p.pos[i], p.vel[i], p.force[i]);
        if !(x.iter().chain(v.iter()).chain(f.iter()).all(|c| c.is_finite())) {
            return Err(unstable(m, i, "has a non-finite position, velocity or force".into()));
        }
        let travel = v.norm() * dt;
        if travel > RUNAWAY_STEP_FRACTION * p.radius[i] {
            return Err(unstable(
                m,
                i,
                format!(
                    "moves {:.0}% of its radius per step (speed {:.3e} m/s)",
                    100.0 * travel / p.radius[i],
                    v.norm()
                ),
            ));
        }
    }
    let (c, sep) = (&m.contacts, m.separations());
    let ratio = m.settings.max_overlap_ratio;
    for i in 0..p.len() {
        for k in c.row(i) {
            let j = c.other[k] as usize;
            let share = overlap_share(m, &sep, i, j);
            if share > ratio {
                let what = format!("overlaps particle {j} by {:.0}% of the smaller radius", 100.0 * share);
                return Err(with_load_fix(m, unstable(m, i, what), &[i, j]));
            }
        }
        for w in &m.walls {
            let (_, gap) = w.normal_and_distance(&p.pos[i]);
            if p.radius[i] - gap > ratio * p.radius[i] {
                return Err(with_load_fix(m, unstable(m, i, format!("is pushed through wall `{}`", w.name)), &[i]));
            }
        }
    }
    Ok(())
}

/// The overlap of particles i and j as a share of the smaller radius (negative apart): what
/// the guard holds below `max_overlap_ratio`.
#[inline(always)]
fn overlap_share(m: &Model, sep: &Separations, i: usize, j: usize) -> f64 {
    let p = &m.particles;
    let overlap = p.radius[i] + p.radius[j] - sep.between(&p.pos, i, j).norm();
    overlap / p.radius[i].min(p.radius[j])
}

/// The deepest particle–particle overlap and its pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeepestOverlap {
    /// Overlap over the smaller radius; the guard stops a run above `max_overlap_ratio`.
    pub share: f64,
    pub i: usize,
    pub j: usize,
}

/// The deepest overlap of any touching pair (`None` when none touches), so that a procedure
/// can stop loading before the guard stops the run: a cone pushed until the grains beside
/// it are pressed deeper than a linear spring means anything (examples/cpt). The rows must
/// be current, as after any step.
pub fn deepest_overlap(m: &Model) -> Option<DeepestOverlap> {
    let (c, sep) = (&m.contacts, m.separations());
    let mut deepest: Option<DeepestOverlap> = None;
    for i in 0..m.len() {
        for k in c.row(i) {
            let j = c.other[k] as usize;
            let share = overlap_share(m, &sep, i, j);
            if share > 0.0 && deepest.is_none_or(|d| share > d.share) {
                deepest = Some(DeepestOverlap { share, i: i.min(j), j: i.max(j) });
            }
        }
    }
    deepest
}

/// A deep overlap with dt under the critical step: the step is not the likely cause, so the
/// general fix ("halve dt") would send the user the wrong way. Names the load instead, and
/// the loading walls that touch the particles when they carry it on few contacts (a platen
/// resting on one grain of an uneven top: the quick oedometer with seed 2 at 0.8 MPa).
fn with_load_fix(m: &Model, mut e: Error, particles: &[usize]) -> Error {
    let Error::Unstable(inst) = &mut e else { return e };
    // A NaN critical step (no element to estimate it from) keeps the general fix too.
    if inst.dt > inst.critical_dt || inst.critical_dt.is_nan() {
        return e;
    }
    let p = &m.particles;
    let walls: Vec<String> = (m.walls.iter())
        .filter_map(|w| {
            let i = *particles.iter().find(|&&i| p.radius[i] > w.normal_and_distance(&p.pos[i]).1)?;
            Some(format!(
                "wall `{}` presses on particle {i} with {:.3e} N on {} contact(s){}",
                w.name,
                w.normal_force,
                w.contacts,
                if w.contacts <= 3 { ", so its whole load goes through one or a few grains" } else { "" }
            ))
        })
        .collect();
    let walls = if walls.is_empty() { String::new() } else { format!(" ({})", walls.join("; ")) };
    inst.fix = Some(format!(
        "Fix: dt is {:.2} of the critical step, so the step is most likely not the cause but the load{walls}: the \
         grains are pressed harder than their stiffness carries at a small overlap. Spread the load over more \
         grains (a larger sample, a flatter surface under the loading wall), load less, or stiffen the material (Kn, \
         or E for Hertz). To rule the step out, halve dt (to {:.3e} s) and run again",
        inst.dt / inst.critical_dt,
        inst.dt / 2.0
    ));
    e
}

pub(crate) fn unstable(m: &Model, particle: usize, what: String) -> Error {
    let (_, critical_dt) = m.critical_dt().unwrap_or((particle, f64::NAN));
    Error::Unstable(Box::new(Instability {
        step: m.clock.step,
        particle,
        what,
        dt: m.clock.dt,
        critical_dt,
        standard_dt: m.standard_dt().unwrap_or(f64::NAN),
        fix: None,
        // The general fix's number (see `Instability`'s Display): a dt under the critical step.
        suggest: if m.clock.dt > critical_dt { vec![Suggestion::below("dt", critical_dt, "s")] } else { Vec::new() },
    }))
}

/// The guard stops a run whose dt exceeds this fraction of the critical step of its stiffest
/// current contact, `critical_step(m, k)` = √(2·m/k) with k the contact's larger tangent
/// stiffness (normal or shear) and m the lighter free element's mass — the convention of
/// [`Model::critical_dt`], so that a contact as stiff as an element's own estimate has the
/// same critical step.
///
/// NOTE: why less than 1. √(2·m/k) is the limit of one element between two such springs; a
/// grain in a packing meets several at once (Z ≈ 4–8), two on a side already bring it to
/// 1/√2 ≈ 0.7 of a contact's limit, and well before the limit the step resolves the contact's
/// oscillation too coarsely for quasi-static loading. MatDEM's standard step is 2π/50/√2 ≈
/// 0.089 of an element's own critical step. Measured on the quick oedometer
/// (examples/oedometer, sample 1, Hertz with E = Kn/(πR) and a shear spring Ks, ring walls):
/// the loaded sample's stiffest contact is a small grain's shear spring on a wall (2·Ks =
/// 8.4e5 N/m, critical step 4.6e-7 s); the standard step is 0.21 of its critical step, 3× is
/// 0.63 (void ratio, strain and coordination as at 1×), 4× is 0.83 (strain at 3.2 MPa 13.9 %
/// against 10.2 %, coordination 3.2 against 4.4) and 5× is 1.05 (void ratio 0.69 against
/// 1.04). 0.7 lets the first two run and stops the others. The GPU kernel uses the same
/// number (`shaders/guard.wgsl`, `STIFFNESS_FRACTION`).
pub const STIFFNESS_FRACTION: f64 = 0.7;

/// The largest length a scene holds (m): every centre within this of the origin, every
/// radius below it.
///
/// NOTE: why a bound at all. Past it the contact arithmetic overflows before the guard can
/// name a cause: an element 1e308 m behind a wall meets it with an infinite Hertz force (δ^1.5),
/// a radius of 1e308 m has no finite mass; the run then stops on a non-finite element, blaming
/// dt, and leaves NaNs in the model. No scene comes near it (a landslide is kilometres): a
/// value beyond is a unit or typing error. At 1e9 m the worst overlap's Hertz force is ~1e26 N.
pub const MAX_LENGTH: f64 = 1e9;

/// The smallest radius an element may have (m): a nanometre, below any grain; a radius of
/// 1e-300 m has a mass of zero.
pub const MIN_RADIUS: f64 = 1e-9;

/// The guard stops a run in which an element moves more than this fraction of its radius in
/// one step (|v|·dt): contacts are then passed through rather than resolved. The GPU guard
/// uses the same number (`shaders/guard.wgsl`).
pub const RUNAWAY_STEP_FRACTION: f64 = 0.5;

/// Gravity alone moves a free particle |g|·dt² further each step; above this fraction of
/// the smallest radius the run is refused and gravity, not dt, is named.
///
/// NOTE: the guard stops a particle that moves half its radius per step; free fall at
/// |g|·dt² = 0.05·r gets there within ten steps, so such a run cannot settle anything. The
/// oedometer's deposition (100 m/s², standard step 97 ns, r ≥ 0.2 mm) is at 5e-9·r.
pub const GRAVITY_STEP_FRACTION: f64 = 0.05;

/// The other body of a contact the guard names.
#[derive(Debug, Clone, PartialEq)]
pub enum ContactWith {
    Particle(usize),
    Wall(String),
}

/// The contact with the shortest critical step, as the guard found it.
#[derive(Debug, Clone, PartialEq)]
pub struct StiffContact {
    /// The lighter free element (the one whose mass enters the critical step).
    pub particle: usize,
    pub with: ContactWith,
    /// Which spring: "hertz normal", "linear normal", "bond", "shear spring", "mindlin shear".
    pub spring: &'static str,
    /// Its tangent stiffness now (N/m).
    pub stiffness: f64,
    /// Overlap now (m; negative for a stretched bond).
    pub overlap: f64,
    /// The mass in the critical step (kg).
    pub mass: f64,
    /// √(2·m/k) (s).
    pub critical_dt: f64,
}

impl StiffContact {
    /// The largest dt the guard accepts for this contact.
    pub fn limit(&self) -> f64 {
        STIFFNESS_FRACTION * self.critical_dt
    }
}

/// Normal and shear tangent stiffness of a contact at overlap δ (bonded pairs in tension:
/// the bond's linear spring), under the plan's laws.
pub fn contact_stiffness(plan: &StepPlan, p: &PairParams, r_star: f64, overlap: f64) -> [(f64, &'static str); 2] {
    let normal = if overlap > 0.0 { plan.normal.stiffness(p, r_star, overlap) } else { (p.kn, "bond normal spring") };
    [normal, plan.tangential.stiffness(p, r_star, overlap)]
}

/// The current contact (particle pair in the rows, bonded or touching, or particle–wall)
/// with the shortest critical step √(2·m/k), or `None` when nothing touches. Reads the rows
/// as they are (the backends call it at a chunk end, where they are current) and only the
/// walls in each particle's wall mask. O(contacts), in parallel; the result is the minimum
/// under a total order (m/k, then ids), so it does not depend on the thread count.
pub fn stiffest_contact(m: &Model, plan: &StepPlan) -> Option<StiffContact> {
    use rayon::prelude::*;
    let p = &m.particles;
    let c = &m.contacts;
    let sep = m.separations();
    let rows = p.len().min(c.row_start.len().saturating_sub(1));
    let near = |i: usize| if c.wall_near.len() == p.len() { c.wall_near[i] } else { u8::MAX };
    let best = (0..p.len())
        .into_par_iter()
        .with_min_len(1024)
        .filter_map(|i| {
            let mut best: Option<Candidate> = None;
            // A spring of no stiffness (Ks = 0, Mindlin at δ = 0) has no critical step.
            let mut consider = |cand: Candidate| {
                if cand.k > 0.0 && best.as_ref().is_none_or(|b| cand.before(b)) {
                    best = Some(cand);
                }
            };
            let free_i = is_free(p, i);
            for e in if i < rows { c.row(i) } else { 0..0 } {
                let j = c.other[e] as usize;
                // Each pair once, from its lower id.
                let free_j = is_free(p, j);
                if j < i || !(free_i || free_j) {
                    continue;
                }
                let overlap = p.radius[i] + p.radius[j] - sep.between(&p.pos, i, j).norm();
                if overlap <= 0.0 && !c.state[e].bonded {
                    continue;
                }
                let (light, other) = match (free_i, free_j) {
                    (true, true) if p.mass[j] < p.mass[i] => (j, i),
                    (true, _) => (i, j),
                    _ => (j, i),
                };
                let r_star = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
                let pp = plan.pair(p.material[i], p.material[j]);
                for (k, spring) in contact_stiffness(plan, pp, r_star, overlap) {
                    consider(Candidate {
                        light,
                        other: Other::Particle(other),
                        spring,
                        k,
                        overlap,
                        mass: p.mass[light],
                    });
                }
            }
            if free_i {
                for (w, wall) in m.walls.iter().enumerate().filter(|(w, _)| near(i) & (1 << w) != 0) {
                    let overlap = p.radius[i] - wall.normal_and_distance(&p.pos[i]).1;
                    if overlap > 0.0 {
                        let pp = plan.wall_pair(w, p.material[i]);
                        for (k, spring) in contact_stiffness(plan, pp, p.radius[i], overlap) {
                            consider(Candidate {
                                light: i,
                                other: Other::Wall(w),
                                spring,
                                k,
                                overlap,
                                mass: p.mass[i],
                            });
                        }
                    }
                }
            }
            best
        })
        .reduce_with(|a, b| if b.before(&a) { b } else { a })?;
    Some(StiffContact {
        particle: best.light,
        with: match best.other {
            Other::Particle(j) => ContactWith::Particle(j),
            Other::Wall(w) => ContactWith::Wall(m.walls[w].name.clone()),
        },
        spring: best.spring,
        stiffness: best.k,
        overlap: best.overlap,
        mass: best.mass,
        critical_dt: critical_step(best.mass, best.k),
    })
}

fn is_free(p: &crate::state::particles::Particles, i: usize) -> bool {
    p.fixed[i] & dof::ALL != dof::ALL
}

/// The other body of a candidate contact, by index.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Other {
    Particle(usize),
    Wall(usize),
}

/// One spring of one contact while the stiffest is sought.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    light: usize,
    other: Other,
    spring: &'static str,
    k: f64,
    overlap: f64,
    mass: f64,
}

impl Candidate {
    /// A shorter critical step (smaller m/k, k > 0; no square root), then lower ids, then the
    /// spring's name: a total order, so the minimum is unique.
    fn before(&self, b: &Candidate) -> bool {
        (self.mass / self.k)
            .total_cmp(&(b.mass / b.k))
            .then((self.light, self.other).cmp(&(b.light, b.other)))
            .then(self.spring.cmp(b.spring))
            .is_lt()
    }
}

/// The stiffest contact if dt exceeds its limit ([`STIFFNESS_FRACTION`] of its critical step).
pub fn too_stiff(m: &Model, plan: &StepPlan) -> Option<StiffContact> {
    stiffest_contact(m, plan).filter(|c| m.clock.dt > c.limit())
}

/// The error (or, with [`GuardMode::Warn`], the warning) for a contact too stiff for dt.
pub fn stiff_contact_error(m: &Model, c: &StiffContact) -> Error {
    let with = match &c.with {
        ContactWith::Particle(j) => format!("particle {j}"),
        ContactWith::Wall(name) => format!("wall `{name}`"),
    };
    let what = format!(
        "is in the stiffest contact, with {with}: its {} is {:.3e} N/m at an overlap of {:.3e} m ({:.2}% of its \
         radius), which with its mass {:.3e} kg gives a critical step √(2m/k) of {:.3e} s; dt is {:.2} of it (the \
         guard allows {STIFFNESS_FRACTION}: a grain meets several such springs at once)",
        c.spring,
        c.stiffness,
        c.overlap,
        100.0 * c.overlap / m.particles.radius[c.particle],
        c.mass,
        c.critical_dt,
        m.clock.dt / c.critical_dt,
    );
    let fix = format!(
        "Fix: set dt ≤ {:.3e} s (d.dt = {:.3e}) or call set_standard_dt() after loading; the standard step comes \
         from each element's own stiffness, and loaded contacts (or stiff shear springs and walls) can be stiffer; \
         or soften the stiffest material. d.guard = \"warn\" warns instead of stopping",
        c.limit(),
        c.limit()
    );
    let mut e = unstable(m, c.particle, what);
    if let Error::Unstable(inst) = &mut e {
        inst.critical_dt = c.critical_dt;
        inst.fix = Some(fix);
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::Material;
    use crate::model::NormalKind;
    use crate::neighbours::rebuild;
    use crate::physics::Vec3;
    use crate::walls::Wall;

    fn material(name: &str, young: f64, poisson: f64, ks: f64) -> Material {
        Material {
            name: name.into(),
            density: 2650.0,
            kn: 1e6,
            ks,
            xb: 0.0,
            fs0: 0.0,
            mu_p: 0.0,
            young,
            poisson,
            restitution: 1.0,
            provenance: Default::default(),
        }
    }

    // Hertz's tangent stiffness k = dF/dδ = 2·E*·√(R*·δ) for F = (4/3)·E*·√R*·δ^(3/2)
    // (Johnson 1985 §4), E* and R* of two unlike spheres, and the critical step √(2·m/k)
    // with m the lighter sphere's mass: the guard's numbers against the formulas, to 1e-12.
    #[test]
    fn hertz_tangent_stiffness_critical_step_matches_the_formula() {
        let mut m = Model::new();
        m.settings.normal = NormalKind::Hertz;
        let a = m.add_material(material("a", 7.0e9, 0.25, 0.0)).unwrap();
        let b = m.add_material(material("b", 3.0e9, 0.1, 0.0)).unwrap();
        let (r1, r2, overlap) = (1.0e-3, 0.6e-3, 2.0e-6);
        m.add_particle(Vec3::zeros(), r1, a).unwrap();
        m.add_particle(Vec3::new(r1 + r2 - overlap, 0.0, 0.0), r2, b).unwrap();
        m.set_standard_dt().unwrap();
        rebuild(&mut m);
        let plan = StepPlan::build(&m);
        let c = stiffest_contact(&m, &plan).expect("the spheres touch");

        let e_star = 1.0 / ((1.0 - 0.25f64.powi(2)) / 7.0e9 + (1.0 - 0.1f64.powi(2)) / 3.0e9);
        let r_star = r1 * r2 / (r1 + r2);
        let k = 2.0 * e_star * (r_star * overlap).sqrt();
        let light = 2650.0 * 4.0 / 3.0 * std::f64::consts::PI * r2.powi(3);
        let expected = (2.0 * light / k).sqrt();
        let rel = |x: f64, y: f64| (x - y).abs() / y.abs();
        assert_eq!(c.particle, 1, "the lighter sphere");
        assert_eq!(c.with, ContactWith::Particle(0));
        assert_eq!(c.spring, "hertz normal stiffness");
        assert!(rel(c.overlap, overlap) < 1e-9, "overlap {} vs {overlap}", c.overlap);
        // The overlap comes from positions (round-off ~1e-10 of it): compare the formula at
        // the guard's own overlap to 1e-12, and the analytic value at δ to the round-off.
        let k_at = 2.0 * e_star * (r_star * c.overlap).sqrt();
        assert!(rel(c.stiffness, k_at) < 1e-12, "k {} vs {k_at}", c.stiffness);
        assert!(rel(c.critical_dt, (2.0 * light / k_at).sqrt()) < 1e-12);
        assert!(rel(c.critical_dt, expected) < 1e-9, "critical step {} vs {expected}", c.critical_dt);
        assert!(rel(c.mass, light) < 1e-12);
        // The standard step of this pair is far from the limit; 10× the critical step is not.
        assert!(too_stiff(&m, &plan).is_none());
        m.clock.dt = 0.71 * c.critical_dt;
        assert_eq!(too_stiff(&m, &plan).map(|c| c.particle), Some(1));
    }

    // Three spheres in a line, the outer pair overlapping the middle one by 10 % and 30 % of
    // the smaller radius: the deepest pair and its share, as the guard's limit measures it.
    #[test]
    fn deepest_overlap_names_the_deepest_pair_and_its_share_of_the_smaller_radius() {
        let mut m = Model::new();
        let k = m.add_material(material("a", 5.0e8, 0.2, 1e5)).unwrap();
        let (big, small) = (1.0e-3, 0.5e-3);
        m.add_particle(Vec3::zeros(), big, k).unwrap();
        m.add_particle(Vec3::new(big + small - 0.1 * small, 0.0, 0.0), small, k).unwrap();
        m.add_particle(Vec3::new(-(big + small - 0.3 * small), 0.0, 0.0), small, k).unwrap();
        m.set_standard_dt().unwrap();
        rebuild(&mut m);
        let d = deepest_overlap(&m).expect("two pairs touch");
        assert_eq!((d.i, d.j), (0, 2));
        assert!((d.share - 0.3).abs() < 1e-12, "share {}", d.share);
        // Apart: nothing to name.
        m.particles.pos[1].x = 1.0;
        m.particles.pos[2].x = -1.0;
        assert_eq!(deepest_overlap(&m), None);
    }

    // The same contact seen by a single element's estimate (a rigid wall at 5% of r) has the
    // same critical step: the contact convention agrees with `Model::critical_dt`.
    #[test]
    fn a_wall_contact_at_five_percent_overlap_has_the_elements_critical_step() {
        let mut m = Model::new();
        m.settings.normal = NormalKind::Hertz;
        let k = m.add_material(material("a", 5.0e8, 0.2, 0.0)).unwrap();
        let r = 1e-3;
        m.add_wall(crate::walls::Wall::plane("floor", Vec3::zeros(), Vec3::z(), 1.0).unwrap()).unwrap();
        m.add_particle(Vec3::new(0.0, 0.0, 0.95 * r), r, k).unwrap();
        m.set_standard_dt().unwrap();
        rebuild(&mut m);
        let c = stiffest_contact(&m, &StepPlan::build(&m)).unwrap();
        assert_eq!(c.with, ContactWith::Wall("floor".into()));
        let (_, element) = m.critical_dt().unwrap();
        assert!((c.critical_dt - element).abs() < 1e-9 * element, "{} vs {element}", c.critical_dt);
    }

    // The GPU guard kernel tests the same limit.
    #[test]
    fn the_gpu_kernel_uses_the_same_stiffness_fraction() {
        let wgsl = include_str!("../../shaders/guard.wgsl");
        let line = format!("const STIFFNESS_FRACTION: f32 = {STIFFNESS_FRACTION:?};");
        assert!(wgsl.contains(&line), "shaders/guard.wgsl must hold `{line}`");
    }

    // A platen resting on one grain of an uneven top squeezes it into the grain below: a deep
    // overlap at the standard step. The step is not the cause, so the fix names the load and
    // the wall carrying it on one contact, and does not send the user to set_standard_dt.
    #[test]
    fn a_deep_overlap_under_the_critical_step_names_the_load_not_dt() {
        let mut m = Model::new();
        let k = m.add_material(material("a", 1.7e9, 0.0, 4e5)).unwrap();
        let (r1, r2) = (0.55e-3, 0.22e-3);
        m.add_particle(Vec3::zeros(), r1, k).unwrap();
        let z2 = r1 + r2 - 0.6 * r2;
        m.add_particle(Vec3::new(0.0, 0.0, z2), r2, k).unwrap();
        let mut platen = Wall::plane("top_platen", Vec3::new(0.0, 0.0, z2 + 0.9 * r2), -Vec3::z(), 2e-5).unwrap();
        (platen.contacts, platen.normal_force) = (1, 15.7);
        m.add_wall(platen).unwrap();
        m.set_standard_dt().unwrap();
        rebuild(&mut m);
        let msg = check_state(&m).unwrap_err().to_string();
        assert!(msg.contains("particle 0 overlaps particle 1 by 60%"), "{msg}");
        assert!(msg.contains("not the cause but the load"), "{msg}");
        assert!(msg.contains("wall `top_platen` presses on particle 1 with 1.570e1 N on 1 contact(s)"), "{msg}");
        assert!(!msg.contains("set_standard_dt"), "{msg}");

        // Above the critical step the general fix (a smaller step) stands.
        m.clock.dt = 2.0 * m.critical_dt().unwrap().1;
        let msg = check_state(&m).unwrap_err().to_string();
        assert!(msg.contains("set_standard_dt") && !msg.contains("the load"), "{msg}");
    }

    #[test]
    fn gravity_that_outruns_the_radius_is_named_not_dt() {
        let mut m = Model::new();
        let k = m.add_material(material("a", 5.0e8, 0.2, 0.0)).unwrap();
        m.add_particle(Vec3::zeros(), 1e-3, k).unwrap();
        m.set_standard_dt().unwrap();
        m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
        check_time_step(&m).unwrap();
        m.settings.gravity = Vec3::new(0.0, 0.0, -1e12);
        let msg = check_time_step(&m).unwrap_err().to_string();
        assert!(msg.starts_with("gravity is the cause: |g| = 1.000e12 m/s²"), "{msg}");
        assert!(msg.contains("9.81 m/s²") && msg.contains("must stay under"), "{msg}");
        assert!(!msg.contains("halve dt"), "{msg}");
    }
}
