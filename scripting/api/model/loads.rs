//! Applied loads (the `applied_loads` stage): an external force or torque on a selection of
//! elements, constant until changed (MatDEM sets `d.mo.mGX` … by hand for the same purpose), and
//! the rotation angles the integrator accumulates with rotation on (`d.ax`, `d.ay`, `d.az`).
//! A selection is a group name, `"all"`, an array of ids or a mask, as everywhere.

use super::*;

/// `d.apply_force(group or ids or mask, [fx, fy, fz])`: the external force (N) each selected
/// element carries from now on, replacing the one it had; `[0, 0, 0]` removes it. Constant until
/// changed, added to the element's force every step (the `applied_loads` stage); its work F·Δx is
/// booked in the energy account (`d.energies().applied_work`). A bad vector (NaN, infinite, not
/// three numbers) or selection is refused and nothing changes.
fn apply_force(d: &mut ModelHandle, sel: Dynamic, force: Array) -> RhaiResult<()> {
    let force = vec3(&Dynamic::from_array(force), "apply_force")?;
    let mut m = d.model();
    let ids = resolve_ids(&m, &sel)?;
    m.apply_force(&ids, force).map_err(raise)
}

/// `d.apply_torque(group or ids or mask, [tx, ty, tz])`: the external torque (N·m) each selected
/// element carries from now on, as `d.apply_force` does a force; its work T·Δθ is booked. A torque
/// needs the elements to turn: rotation is switched on.
fn apply_torque(d: &mut ModelHandle, sel: Dynamic, torque: Array) -> RhaiResult<()> {
    let torque = vec3(&Dynamic::from_array(torque), "apply_torque")?;
    let mut m = d.model();
    let ids = resolve_ids(&m, &sel)?;
    m.apply_torque(&ids, torque).map_err(raise)
}

/// `d.clear_applied_loads()`: removes every applied force and torque; the work they did stays in
/// the energy account, and the stage leaves the plan.
fn clear_applied_loads(d: &mut ModelHandle) {
    d.model().clear_applied_loads();
}

/// The component `k` of each element's applied force (`torque` false) or torque (N or N·m; 0
/// where none).
fn applied(m: &Model, torque: bool, k: usize) -> Field {
    let a = &m.particles.applied;
    let lane = if torque { &a.torque } else { &a.force };
    Field::new((0..m.len()).map(|i| lane.get(i).map_or(0.0, |v| v[k])).collect())
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine
        .register_fn("apply_force", apply_force)
        .register_fn("apply_torque", apply_torque)
        .register_fn("clear_applied_loads", clear_applied_loads);
    // The loads as whole arrays: d.applied_fx … d.applied_tz (0 where an element has none).
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        for (torque, name) in [(false, format!("applied_f{axis}")), (true, format!("applied_t{axis}"))] {
            engine.register_get(&name, move |d: &mut ModelHandle| applied(&d.model(), torque, k));
        }
    }
    // The accumulated rotation θ = ∫ω dt about x, y and z (rad), with rotation on.
    for (k, name) in ["ax", "ay", "az"].into_iter().enumerate() {
        let h = host.clone();
        engine.register_get(name, move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
            h.observe(name, || {
                let m = d.model();
                let rot = m.particles.rotation.as_ref().ok_or_else(|| {
                    err(format!(
                        "`{name}`: rotation is off, so the model has no rotation angles; switch it on first with \
                         d.enable(\"rotation\") (an applied torque switches it on too)"
                    ))
                })?;
                Ok(Dynamic::from(Field::new(rot.angle.iter().map(|a| a[k]).collect())))
            })
        });
    }
}
