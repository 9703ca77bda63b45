// The `guard` stage on the GPU: the stability guard's checks (non-finite state, a particle moving
// more than half its radius per step, deep overlaps, a particle pushed through a wall, and a
// contact too stiff for dt). Each kind keeps the lowest particle id that fails it; the host then
// words the same message as the CPU guard (for a stiff contact it finds the contact again, in f64,
// on the state it downloads). Runs once per slab of rows, at chunk ends only. CPU twin: guard.rs.

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

// guard.rs STIFFNESS_FRACTION: dt may be at most this fraction of a contact's critical step
// √(2·m/k), k its larger tangent stiffness, m the lighter free element's mass.
const STIFFNESS_FRACTION: f32 = 0.7;

// Whether dt exceeds the guard's limit for a contact of tangent stiffnesses kn, kt and mass m:
// dt > f·√(2m/k) ⇔ dt²·k > f²·2m, without a square root.
fn too_stiff(kn: f32, kt: f32, m: f32) -> bool {
    let dt2 = params.dt * params.dt;
    return dt2 * max(kn, kt) > STIFFNESS_FRACTION * STIFFNESS_FRACTION * 2.0 * m;
}

// Free in translation: not every translational degree of freedom blocked (kind's bits 24–26).
fn is_free(i: u32) -> bool {
    return ((kind[i] >> 24u) & 7u) != 7u;
}

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
    let end = row_end(local, row_len[i], slab.count);
    let mi = body[i].x;
    let mati = kind[i] & 0xffffu;
    let free_i = is_free(i);
    var deep = false;
    var stiff = false;
    for (var e = local; e < end; e += slab.count) {
        let j = other[e];
        let rj = origin[j].w;
        let d = nearest_image((origin[j].xyz - oi) + (disp[j].xyz - ui));
        let overlap = ri + rj - length(d);
        if overlap > ratio * min(ri, rj) {
            deep = true;
        }
        // Each row checks all its contacts; the test is the same from both ends of a pair.
        let free_j = is_free(j);
        if (overlap > 0.0 || state[e].w != 0.0) && (free_i || free_j) {
            let p = pairs[mati * params.nmat + (kind[j] & 0xffffu)];
            let r_star = ri * rj / (ri + rj);
            var kn = p.kn;
            if overlap > 0.0 {
                kn = normal_stiffness(p, r_star, overlap);
            }
            var m = min(mi, body[j].x);
            if !free_j {
                m = mi;
            } else if !free_i {
                m = body[j].x;
            }
            stiff = stiff || too_stiff(kn, shear_stiffness(p, r_star, overlap), m);
        }
    }
    if deep {
        atomicMin(&counters[C_GUARD + 2u], i);
    }
    for (var w = 0u; w < params.nw; w++) {
        let ng = wall_normal_and_gap(walls[w], oi, ui);
        let overlap = ri - ng.w;
        if overlap > ratio * ri {
            atomicMin(&counters[C_GUARD + 3u], i);
            break;
        }
        if overlap > 0.0 && free_i {
            let p = wall_pairs[w * params.nmat + mati];
            stiff = stiff || too_stiff(normal_stiffness(p, ri, overlap), shear_stiffness(p, ri, overlap), mi);
        }
    }
    if stiff {
        atomicMin(&counters[C_STIFF], i);
    }
}
