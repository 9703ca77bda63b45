// The `moisture` stage on the GPU: one field step of moisture diffusion in forward-Euler
// sub-steps of the shared core (diffusion.wgsl, prepended), then the coupling. Each element
// sums its own row (G = α·π·a², α the series mean of the two diffusivities, a the Hertz
// radius √(R*·δ), at least the bond's neck for a bonded pair), plus its evaporation
// E = χ·π·r² towards the ambient water content, and writes only its own next water content
// and ΣG; `settle` makes the next contents current; `shrink` sets r = r0·f_r(ω) in origin.w
// (which every stage reads as the radius), `shrink_expand` the same times the thermal
// expansion's factor when heat expands the elements too; `strengthen` sets each bond's share of its
// strength s(ω̄) in state.w, ω̄ the pair's mean, quantised as the CPU's u16 share is.
// No atomics. CPU twin: effects/moisture/cpu.rs (effects/moisture/physics.rs for the laws).

const PI: f32 = 3.14159265358979;

struct Moisture {
    // One forward-Euler sub-step (s).
    dt: f32,
    // A bond's neck radius as a fraction of the smaller radius.
    bond_radius: f32,
    // Points of the radius table (then the strength table's) in `tables`.
    radius_points: u32,
    strength_points: u32,
    // T0 of thermal expansion, when the radius is the product of both factors.
    reference: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

fn field_value(j: u32) -> f32 {
    return water[j].x;
}

fn field_sealed(j: u32) -> bool {
    return mode[j] == FIELD_SEALED;
}

fn field_pair(i: u32, j: u32, ri: f32, rj: f32, dist: f32, bonded: bool) -> f32 {
    let ai = water[i].z;
    let aj = water[j].z;
    let overlap = ri + rj - dist;
    var a = 0.0;
    if overlap > 0.0 {
        a = sqrt(ri * rj / (ri + rj) * overlap);
    }
    if bonded {
        a = max(a, field.bond_radius * min(ri, rj));
    }
    if a > 0.0 && ai + aj > 0.0 {
        return 2.0 * ai * aj / (ai + aj) * PI * a * a;
    }
    return 0.0;
}

// Table::at: piecewise linear over `count` points from `first`, flat beyond the ends.
fn table_at(first: u32, count: u32, w: f32) -> f32 {
    if w <= tables[first].x {
        return tables[first].y;
    }
    for (var k = 1u; k < count; k++) {
        let p1 = tables[first + k];
        if w <= p1.x {
            let p0 = tables[first + k - 1u];
            return p0.y + (p1.y - p0.y) * (w - p0.x) / (p1.x - p0.x);
        }
    }
    return tables[first + count - 1u].y;
}

@compute @workgroup_size(64)
fn exchange(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = invocation(gid, groups);
    if local >= slab.count {
        return;
    }
    let i = slab.first + local;
    let wi = water[i];
    let r = origin[i].w;
    let e = wi.w * PI * r * r;
    let x = row_exchange(i, local, wi.x, Exchange(e * (ambient[i] - wi.x), e));
    conductance[i] = x.g;
    if mode[i] == FIELD_FIXED {
        next[i] = wi.x;
    } else {
        next[i] = wi.x + field.dt * x.q / wi.y;
    }
}

@compute @workgroup_size(64)
fn settle(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    water[i].x = next[i];
}

@compute @workgroup_size(64)
fn shrink(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    origin[i].w = radius0[i] * table_at(0u, field.radius_points, water[i].x);
}

// With thermal expansion too: r = r0·f(ω)·(1 + α·(T − T0)); the expansion's r0 becomes
// r0·f(ω), which conduction's `expand` multiplies by its factor until the next field step.
@compute @workgroup_size(64)
fn shrink_expand(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    let base = radius0[i] * table_at(0u, field.radius_points, water[i].x);
    let e = expansion[i];
    expansion[i] = vec2<f32>(e.x, base);
    origin[i].w = base * (1.0 + e.x * (thermal[i].x - field.reference));
}

@compute @workgroup_size(64)
fn strengthen(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = invocation(gid, groups);
    if local >= slab.count {
        return;
    }
    let i = slab.first + local;
    let end = row_end(local, row_len[i], slab.count);
    for (var e = local; e < end; e += slab.count) {
        if state[e].w != 0.0 {
            let j = other[e];
            let s = table_at(field.radius_points, field.strength_points, 0.5 * (water[i].x + water[j].x));
            // PairState::weakened_for: the share in steps of 1/65535, never none of it.
            let weakened = clamp(round((1.0 - s) * 65535.0), 0.0, 65534.0);
            state[e].w = 1.0 - weakened / 65535.0;
        }
    }
}
