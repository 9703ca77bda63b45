// The `rolling_resistance` stage on the GPU: one invocation per particle walks its own
// neighbour row and the walls, and adds to its torque each contact's rolling resistance
// (engine/src/effects/rolling_resistance/physics.rs, line for line, in f32): cdt, −μ_r·R_eff·Fn·ω̂_t
// capped at I_eff·|ω_t|/dt; or, with ROLLING_SPRING (common.wgsl), epsd's rolling spring, kept
// per row entry and per wall in this slab's lanes. Each pair is evaluated from both rows with
// exactly opposite inputs, so no float atomics. The torques' work −M·ω_rel·dt goes to the heat
// ledger's friction lane: half of each pair's from each row, all of a wall contact's. Runs once
// per slab of rows, after wall_forces, before integrate. CPU twin: engine/src/effects/rolling_resistance/cpu.rs.

// The rolling resistance coefficient μ_r and epsd's viscous damping ratio η_r, set for this
// pipeline only.
override ROLLING_MU: f32 = 0.0;
override ROLLING_DAMPING: f32 = 0.0;

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

// I_i·I_j/(I_i + I_j), symmetric in its arguments bit for bit (pair_inertia).
fn pair_inertia(a: f32, b: f32) -> f32 {
    if a + b > 0.0 {
        return a * b / (a + b);
    }
    return 0.0;
}

// cdt's torque on this element for a contact of normal n (towards the other body), relative
// angular velocity w_rel, R_eff, elastic normal force fn_el and I_eff (cdt_torque).
fn cdt_torque(n: vec3<f32>, w_rel: vec3<f32>, r_eff: f32, fn_el: f32, inertia: f32, dt: f32) -> vec3<f32> {
    let wt = w_rel - n * dot(n, w_rel);
    let w2 = dot(wt, wt);
    if w2 == 0.0 || fn_el <= 0.0 {
        return vec3<f32>(0.0);
    }
    let w = sqrt(w2);
    let m = min(ROLLING_MU * r_eff * fn_el, inertia * w / dt);
    return wt * (-m / w);
}

// epsd's torque on this element: the spring carried into the tangent plane, incremented by
// −k_r·ω_t·dt (k_r = kt·R_eff²) and capped at μ_r·R_eff·Fn, plus −C_r·ω_t below the cap
// (epsd_torque). Updates `spring`.
fn epsd_torque(n: vec3<f32>, w_rel: vec3<f32>, r_eff: f32, fn_el: f32, inertia: f32, kt: f32,
               spring: ptr<function, vec3<f32>>, dt: f32) -> vec3<f32> {
    let wt = w_rel - n * dot(n, w_rel);
    let kr = kt * r_eff * r_eff;
    var s = rotate_into_plane(*spring, n) - wt * (kr * dt);
    let limit = ROLLING_MU * r_eff * max(fn_el, 0.0);
    let s2 = dot(s, s);
    if s2 > limit * limit {
        s = s * (limit / sqrt(s2));
        *spring = s;
        return s;
    }
    *spring = s;
    if ROLLING_DAMPING > 0.0 {
        return s - wt * (2.0 * ROLLING_DAMPING * sqrt(inertia * kr));
    }
    return s;
}

@compute @workgroup_size(64)
fn rolling_resistance(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = invocation(gid, groups);
    if local >= slab.count {
        return;
    }
    let i = slab.first + local;
    let oi = origin[i].xyz;
    let ui = disp[i].xyz;
    let ri = origin[i].w;
    let wi = ang_vel[i].xyz;
    let ii = 0.4 * body[i].x * ri * ri;
    let mati = kind[i] & 0xffffu;
    let dt = params.dt;
    var t = vec3<f32>(0.0);
    // The work the torques take: whole pairs, whole wall contacts.
    var pair_heat = 0.0;
    var wall_heat = 0.0;
    let end = row_end(local, row_len[i], slab.count);
    for (var e = local; e < end; e += slab.count) {
        let j = other[e];
        // Both parts of the position differ little between neighbours: subtract each first.
        let d = nearest_image((origin[j].xyz - oi) + (disp[j].xyz - ui));
        let rj = origin[j].w;
        let touch = ri + rj;
        let dist2 = dot(d, d);
        if dist2 >= touch * touch {
            // Apart: the rolling spring lets go with the contact.
            if ROLLING_SPRING && any(rolling[e] != vec4<f32>(0.0)) {
                rolling[e] = vec4<f32>(0.0);
            }
            continue;
        }
        let dist = sqrt(dist2);
        let r_eff = ri * rj / touch;
        let p = pairs[mati * params.nmat + (kind[j] & 0xffffu)];
        let ij = 0.4 * body[j].x * rj * rj;
        let overlap = touch - dist;
        let fn_el = normal_force(p, r_eff, overlap);
        let w_rel = wi - ang_vel[j].xyz;
        var m: vec3<f32>;
        if ROLLING_SPRING {
            var s = rolling[e].xyz;
            m = epsd_torque(d / dist, w_rel, r_eff, fn_el, pair_inertia(ii, ij), shear_stiffness(p, r_eff, overlap),
                            &s, dt);
            rolling[e] = vec4<f32>(s, 0.0);
        } else {
            m = cdt_torque(d / dist, w_rel, r_eff, fn_el, pair_inertia(ii, ij), dt);
        }
        t += m;
        pair_heat -= dot(m, w_rel) * dt;
    }
    for (var w = 0u; w < params.nw; w++) {
        let ng = wall_normal_and_gap(walls[w], oi, ui);
        let overlap = ri - ng.w;
        let k = row_slot(local, w, slab.count);
        if overlap <= 0.0 {
            if ROLLING_SPRING && any(wall_rolling[k] != vec4<f32>(0.0)) {
                wall_rolling[k] = vec4<f32>(0.0);
            }
            continue;
        }
        let p = wall_pairs[w * params.nmat + mati];
        let fn_el = normal_force(p, ri, overlap);
        var m: vec3<f32>;
        if ROLLING_SPRING {
            var s = wall_rolling[k].xyz;
            m = epsd_torque(-ng.xyz, wi, ri, fn_el, ii, shear_stiffness(p, ri, overlap), &s, dt);
            wall_rolling[k] = vec4<f32>(s, 0.0);
        } else {
            m = cdt_torque(-ng.xyz, wi, ri, fn_el, ii, dt);
        }
        t += m;
        wall_heat -= dot(m, wi) * dt;
    }
    torque[i] = vec4<f32>(torque[i].xyz + t, 0.0);
    let h = 0.5 * pair_heat + wall_heat;
    if HEAT_FRICTION != HEAT_OFF && h != 0.0 {
        let k = ledger_index(i, HEAT_FRICTION, params.n);
        heat[k] = ledger_add(heat[k], h, params.one);
    }
}
