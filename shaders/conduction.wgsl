// The `conduction` stage on the GPU: one field step of heat conduction in forward-Euler
// sub-steps of the shared diffusion core (diffusion.wgsl, prepended), then thermal expansion.
// Each element sums its own row (the pairs that overlap or are bonded, H = 4·a·k1·k2/(k1 + k2)
// with a the Hertz radius √(R*·δ), at least the bond's neck for a bonded pair) and writes only
// its own next temperature and ΣH; `settle` then makes the
// next temperatures current, and `expand` sets r = r0·(1 + α·(T − T0)) in origin.w, which every
// stage reads as the radius. With the dissipated heat fed in (the plan's `dissipation`), `feed`
// first adds to each free element's temperature the heat its ledger slots (heat_ledger.wgsl; damping,
// contact damping, friction, breakage, not wall work) booked since the last field step, over
// its capacity. No atomics. CPU twin: effects/conduction/cpu.rs.

// Some element expands (the plan's `expansion`).
override EXPANSION: bool = false;


struct Conduction {
    // One forward-Euler sub-step (s).
    dt: f32,
    // A bond's neck radius as a fraction of the smaller radius.
    bond_radius: f32,
    // T0, where radii are r0.
    reference: f32,
    pad: f32,
}

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

fn field_value(j: u32) -> f32 {
    return thermal[j].x;
}

fn field_sealed(j: u32) -> bool {
    return mode[j] == FIELD_SEALED;
}

fn field_pair(i: u32, j: u32, ri: f32, rj: f32, dist: f32, bonded: bool) -> f32 {
    return pair_conductance(thermal[i].z, thermal[j].z, ri, rj, dist, bonded);
}

fn pair_conductance(ki: f32, kj: f32, ri: f32, rj: f32, dist: f32, bonded: bool) -> f32 {
    let overlap = ri + rj - dist;
    var a = 0.0;
    if overlap > 0.0 {
        a = sqrt(ri * rj / (ri + rj) * overlap);
    }
    if bonded {
        a = max(a, field.bond_radius * min(ri, rj));
    }
    if a > 0.0 && ki + kj > 0.0 {
        return 4.0 * a * ki * kj / (ki + kj);
    }
    return 0.0;
}

@compute @workgroup_size(64)
fn conduct(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = invocation(gid, groups);
    if local >= slab.count {
        return;
    }
    let i = slab.first + local;
    let ti = thermal[i];
    let x = row_exchange(i, local, ti.x, Exchange(ti.w, 0.0));
    conductance[i] = x.g;
    if mode[i] == FIELD_FIXED {
        next[i] = ti.x;
    } else {
        next[i] = ti.x + field.dt * x.q / ti.y;
    }
}

@compute @workgroup_size(64)
fn settle(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    thermal[i].x = next[i];
}

@compute @workgroup_size(64)
fn expand(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n || !EXPANSION {
        return;
    }
    let e = expansion[i];
    origin[i].w = e.y * (1.0 + e.x * (thermal[i].x - field.reference));
}

// Adds ledger slot `slot` of element i (a compensated pair) to the compensated sum `acc`.
fn add_booked(acc: vec2<f32>, i: u32, slot: u32) -> vec2<f32> {
    if slot == HEAT_OFF {
        return acc;
    }
    let h = heat[ledger_index(i, slot, params.n)];
    return ledger_add(ledger_add(acc, h.x, params.one), h.y, params.one);
}

@compute @workgroup_size(64)
fn feed(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    var booked = add_booked(vec2<f32>(0.0, 0.0), i, HEAT_DAMPING);
    booked = add_booked(booked, i, HEAT_CONTACT_DAMPING);
    booked = add_booked(booked, i, HEAT_FRICTION);
    booked = add_booked(booked, i, HEAT_BREAKAGE);
    let was = fed[i];
    fed[i] = booked;
    // The two sums are close, so hi − hi is exact (Sterbenz) and the new heat keeps the pairs'
    // ~48 bits, though it is ~1e-6 of them after a long run.
    let new_heat = (booked.x - was.x) + (booked.y - was.y);
    let t = thermal[i];
    if mode[i] != FIELD_FIXED && t.y > 0.0 {
        thermal[i].x = t.x + new_heat / t.y;
    }
}
