// The `guard` stage on the GPU: the stability guard's checks (non-finite state, a particle moving
// more than half its radius per step, deep overlaps, a particle pushed through a wall). Each kind
// keeps the lowest particle id that fails it; the host then words the same message as the CPU
// guard. Runs once per slab of rows. CPU twin: guard.rs.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> origin: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> disp: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> vel: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> force: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> row_len: array<u32>;
@group(0) @binding(6) var<storage, read> other: array<u32>;
@group(0) @binding(7) var<storage, read> walls: array<Wall>;
@group(0) @binding(8) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(9) var<uniform> slab: Slab;

// Infinity or NaN: all exponent bits set (WGSL has no isnan, and fast-math may fold x != x).
fn non_finite(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return any(e == vec3<u32>(0x7f800000u));
}

@compute @workgroup_size(64)
fn check_state(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = invocation(gid, groups);
    if local >= slab.count {
        return;
    }
    let i = slab.first + local;
    let oi = origin[i].xyz;
    let ri = origin[i].w;
    let ui = disp[i].xyz;
    let v = vel[i].xyz;
    if non_finite(oi + ui) || non_finite(v) || non_finite(force[i].xyz) {
        atomicMin(&counters[C_GUARD], i);
        return;
    }
    if length(v) * params.dt > 0.5 * ri {
        atomicMin(&counters[C_GUARD + 1u], i);
    }
    let ratio = params.max_overlap_ratio;
    let start = local * params.cap;
    let end = start + row_len[i];
    for (var e = start; e < end; e++) {
        let j = other[e];
        let rj = origin[j].w;
        let d = (origin[j].xyz - oi) + (disp[j].xyz - ui);
        if ri + rj - length(d) > ratio * min(ri, rj) {
            atomicMin(&counters[C_GUARD + 2u], i);
            break;
        }
    }
    for (var w = 0u; w < params.nw; w++) {
        let ng = wall_normal_and_gap(walls[w], oi, ui);
        if ri - ng.w > ratio * ri {
            atomicMin(&counters[C_GUARD + 3u], i);
            break;
        }
    }
}
