// The pore fluid's temperature on the GPU (f32), with the heat field (`conduction`) and pore
// flow both on: the `pore_flow` stage's thermal kernels. Appended to pore_flow.wgsl (its
// bindings, `between`, `solid_angle`), built only when the plan's pore flow is `thermal`;
// the isothermal kernels there are untouched.
//
// Each pore keeps its fluid's excess temperature w = T − T0 (K) in `warmth`; kernels that change
// it write `warmth_next`, which `pore_pressure_thermal` or `pore_settle` make current, so that a
// pore reading a neighbour's w never races with the neighbour's update.
//
// - `pore_pressure_thermal` (per pore, once per flow sub-step and once after the last): the
//   advected temperature made current, the held pores' mass (the equation of state with w) and
//   temperature (a reservoir at its region's), both booked to the pore's ledger, then
//   p = K_f·((e − ρ0·(V − V0))/(ρ0·V) + β_f·w) (flow.rs `update_pressure`).
// - `pore_mass_thermal` (per pore, each sub-step): `pore_mass` and the heat the flow carries,
//   upwind: a throat flowing into the pore brings the temperature of the pore it leaves, an
//   injecting region its own (flow.rs `substep`). Written as w + ρ0·h·(Σ_in q·(w_o − w) +
//   s·(w_s − w))/m1, in real arithmetic the CPU's (m0·w + ρ0·h·(Σ q·w_up + s·w_s))/m1.
// - the exchange with the grains (heat.rs `exchange_heat`), once per mechanical step after the
//   flow: `exchange_conductance` (per tetrahedron: G = (Nu/2)·k_f·Ω·r of each corner, 0 at an
//   insulated element or one without capacity), then per sub-step `pore_exchange` (per pore:
//   Σ G·(T_i − T_p) over its tetrahedra's corners), `element_exchange` (per element: Σ G·(T_p −
//   T_i) over its own row of corners, the same products negated, so what one side gains the
//   other loses) and `pore_settle`; each side's stable step C/ΣG into a counter (the host
//   sizes the next batch's sub-steps with it); then `pore_eos_thermal` (pressures with the new
//   w, no holds, as the CPU's `update_pressure` after the exchange).
//
// The excess masses keep their rounding carry as pore_flow.wgsl's `pore_mass` does (its
// `excess_carry` lane and `carried_sum`): in a steady flow a pore's net inflow per sub-step is far
// under the ulp of its excess (~1e-9 kg for a 0.02 kg excess) and the same every sub-step.
//
// Temperatures in f32 lose an increment under half their ulp: ~3e-5 K for an element's absolute
// temperature (the conduction stage's lane, ~300 K), ~4e-6 K for a pore's 60 K excess, while a
// pore takes hundreds of flow sub-steps a step, each warming it by less. Each element and each
// pore keeps what its updates rounded away (`carry`, `warmth_carry`: two-sum), adds it to its
// next increment, and the download adds it back: the updates keep ~48 bits. No float atomics:
// each pore and each element sums its own row.

struct PoreHeat {
    // c_f (J/(kg·K)).
    specific_heat: f32,
    // β_f (1/K).
    expansion: f32,
    // T0 (K).
    reference: f32,
    // One exchange sub-step (s).
    h: f32,
    // (Nu/2)·k_f (W/(m·K)).
    film: f32,
    tets: u32,
    pad: vec2<f32>,
}

const THERMAL_FIXED: u32 = 1u;
const THERMAL_INSULATED: u32 = 2u;

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.
fn fluid_mass(p: u32) -> f32 {
    return fluid_bc[p].w + excess[p];
}

// T_i − T0 of element i, with its carry.
fn grain_warmth(i: u32) -> f32 {
    return (thermal[i].x - ph.reference) + carry[i];
}

@compute @workgroup_size(64)
fn pore_pressure_thermal(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    var w = warmth_next[p];
    let grown = pp.density * (volume[p] - volume0[p]);
    let v = eos_volume(p);
    let bc = boundary[p];
    let hb = fluid_bc[p];
    if bc.z > 0.5 {
        // Held: the excess that gives the fixed pressure at the current volume and temperature;
        // the mass it takes comes at the pore's temperature.
        let held = grown + pp.density * v * (bc.x / pp.bulk_modulus - ph.expansion * w);
        let dm = (held - excess[p]) - excess_carry[p];
        excess_carry[p] = 0.0;
        supplied[p] = ledger_add(supplied[p], dm, pp.one);
        heat_supplied[p] = ledger_add(heat_supplied[p], dm * w, pp.one);
        excess[p] = held;
    }
    if hb.z > 0.5 && (w != hb.x || warmth_carry[p] != 0.0) {
        let held_by = (hb.x - w) - warmth_carry[p];
        heat_supplied[p] = ledger_add(heat_supplied[p], (hb.w + excess[p]) * held_by, pp.one);
        w = hb.x;
        warmth_carry[p] = 0.0;
    }
    warmth[p] = w;
    warmth_next[p] = w;
    pressure[p] = pp.bulk_modulus * ((excess[p] - grown) / (pp.density * v) + ph.expansion * w);
}

@compute @workgroup_size(64)
fn pore_mass_thermal(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    let own = pressure[p];
    let w = warmth[p];
    var inflow = 0.0;
    // Σ over the throats flowing in of q·(w_o − w): the upwind heat less what the mass brings
    // at the pore's own temperature.
    var warming = 0.0;
    for (var e = row_start[p]; e < row_start[p + 1u]; e++) {
        let t = row[e];
        let th = throats[t];
        let other_pore = select(th.a, th.b, th.a == p);
        let q = conductance[t] * (pressure[other_pore] - own);
        inflow += q;
        if q > 0.0 {
            warming += q * (warmth[other_pore] - w);
        }
    }
    let source = boundary[p].y;
    let hb = fluid_bc[p];
    // An injection brings its region's temperature; a draw takes the pore's own.
    var brought = w;
    if hb.y > 0.5 && source > 0.0 {
        brought = hb.x;
    }
    let added = carried_sum(excess[p], pp.density * pp.h * (inflow + source) + excess_carry[p]);
    excess[p] = added.x;
    excess_carry[p] = added.y;
    if source != 0.0 {
        let dm = pp.density * pp.h * source;
        supplied[p] = ledger_add(supplied[p], dm, pp.one);
        heat_supplied[p] = ledger_add(heat_supplied[p], dm * brought, pp.one);
    }
    let m1 = hb.w + excess[p];
    var next = w;
    if m1 > 0.0 {
        let inc = pp.density * pp.h * (warming + source * (brought - w)) / m1;
        let sum = carried_sum(w, inc + warmth_carry[p]);
        next = sum.x;
        warmth_carry[p] = sum.y;
    }
    warmth_next[p] = next;
}

@compute @workgroup_size(64)
fn exchange_conductance(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = invocation(gid, groups);
    if t >= ph.tets {
        return;
    }
    let v = tets[t];
    let e01 = between(v.x, v.y);
    let e02 = between(v.x, v.z);
    let e03 = between(v.x, v.w);
    let e12 = between(v.y, v.z);
    let e13 = between(v.y, v.w);
    let e23 = between(v.z, v.w);
    let omega = vec4<f32>(
        solid_angle(e01, e02, e03),
        solid_angle(e12, e13, -e01),
        solid_angle(e23, -e02, -e12),
        solid_angle(-e03, -e13, -e23)
    );
    var g = vec4<f32>(0.0);
    for (var c = 0u; c < 4u; c++) {
        let i = v[c];
        if thermal_mode[i] != THERMAL_INSULATED && thermal[i].y > 0.0 {
            g[c] = ph.film * omega[c] * origin[i].w;
        }
    }
    corner_g[t] = g;
}

@compute @workgroup_size(64)
fn pore_exchange(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    let w = warmth[p];
    var q = 0.0;
    var g = 0.0;
    for (var k = pore_tet_start[p]; k < pore_tet_start[p + 1u]; k++) {
        let t = pore_tets[k];
        let v = tets[t];
        let gc = corner_g[t];
        q += gc.x * (grain_warmth(v.x) - w) + gc.y * (grain_warmth(v.y) - w) + gc.z * (grain_warmth(v.z) - w)
            + gc.w * (grain_warmth(v.w) - w);
        g += gc.x + gc.y + gc.z + gc.w;
    }
    let capacity = ph.specific_heat * fluid_mass(p);
    if g > 0.0 && fluid_bc[p].z < 0.5 {
        // Positive f32s order like their bits.
        atomicMin(&counters[C_PORE_EXCHANGE], bitcast<u32>(capacity / g));
    }
    var next = w;
    if q != 0.0 {
        let sum = carried_sum(w, ph.h * q / capacity + warmth_carry[p]);
        next = sum.x;
        warmth_carry[p] = sum.y;
    }
    warmth_next[p] = next;
}

@compute @workgroup_size(64)
fn element_exchange(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= pp.elements || thermal_mode[i] == THERMAL_FIXED {
        return;
    }
    let own = grain_warmth(i);
    var q = 0.0;
    var g = 0.0;
    for (var k = elem_start[i]; k < elem_start[i + 1u]; k++) {
        let corner = elem_corners[k];
        let t = corner / 4u;
        let gc = corner_g[t][corner % 4u];
        q += gc * (warmth[tet_pore[t]] - own);
        g += gc;
    }
    let ti = thermal[i];
    if g > 0.0 {
        atomicMin(&counters[C_PORE_EXCHANGE], bitcast<u32>(ti.y / g));
    }
    if q != 0.0 {
        // The rounding error of T + increment, kept for the next update.
        let sum = carried_sum(ti.x, ph.h * q / ti.y + carry[i]);
        thermal[i].x = sum.x;
        carry[i] = sum.y;
    }
}

@compute @workgroup_size(64)
fn pore_settle(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    var w = warmth_next[p];
    let hb = fluid_bc[p];
    if hb.z > 0.5 && (w != hb.x || warmth_carry[p] != 0.0) {
        heat_supplied[p] = ledger_add(heat_supplied[p], fluid_mass(p) * ((hb.x - w) - warmth_carry[p]), pp.one);
        w = hb.x;
        warmth_carry[p] = 0.0;
    }
    warmth[p] = w;
    warmth_next[p] = w;
}

@compute @workgroup_size(64)
fn pore_eos_thermal(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    let grown = pp.density * (volume[p] - volume0[p]);
    let v = eos_volume(p);
    pressure[p] = pp.bulk_modulus * ((excess[p] - grown) / (pp.density * v) + ph.expansion * warmth[p]);
}
