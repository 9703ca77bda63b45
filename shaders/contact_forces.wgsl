// The `contact_forces` stage on the GPU: particle–particle contact forces. One invocation per
// particle walks its own neighbour row, evaluates every contact from its side, updates the row's
// pair state and writes its summed force (and torque): no atomics on floats, so the sums are
// deterministic. Runs once per slab of rows. In a 2D model its vectors are read in the plane
// (`in_plane`, `about_y`): no y arithmetic after specialisation. CPU twin:
// backend/cpu/contact_forces.rs.

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

@compute @workgroup_size(64)
fn compute_contact_forces(@builtin(global_invocation_id) gid: vec3<u32>,
                          @builtin(num_workgroups) groups: vec3<u32>) {
    let local = invocation(gid, groups);
    if local >= slab.count {
        return;
    }
    let i = slab.first + local;
    let oi = origin[i].xyz;
    let ri = origin[i].w;
    let ui = disp[i].xyz;
    let vi = in_plane(vel[i].xyz);
    let mi = body[i].x;
    let mati = kind[i] & 0xffffu;
    var wi = vec3<f32>(0.0);
    if ROTATION {
        wi = about_y(ang_vel[i].xyz);
    }
    let dt = params.dt;
    var f = vec3<f32>(0.0);
    var t = vec3<f32>(0.0);
    // The row's heat (damping, friction, breakage), whole pairs.
    var h = vec3<f32>(0.0);
    let end = row_end(local, row_len[i], slab.count);
    for (var e = local; e < end; e += slab.count) {
        let j = other[e];
        let st = state[e];
        let bonded = st.w != 0.0;
        // Both parts of the position differ little between neighbours: subtract each first.
        let raw = (origin[j].xyz - oi) + (disp[j].xyz - ui);
        let d = in_plane(nearest_image(raw));
        // v_i − v_j gains the slide of j's image under Lees–Edwards shear (0 without).
        let slide = image_slide(raw);
        let rj = origin[j].w;
        let touch = ri + rj;
        let dist2 = dot(d, d);
        if !bonded && dist2 >= touch * touch {
            // Apart: a contact that has just opened lets its shear spring go.
            if any(st != vec4<f32>(0.0)) || dashpot_of(e) != 0.0 {
                h += opened_heat(i, j, e, d, st.xyz, slide);
                state[e] = vec4<f32>(0.0);
            }
            continue;
        }
        let dist = sqrt(dist2);
        let n = d / dist;
        var v_rel = vi - in_plane(vel[j].xyz);
        if SHEAR {
            v_rel.x += slide;
        }
        if ROTATION {
            // Grouped so that the other row computes exactly the opposite vector.
            v_rel = v_rel + (cross(wi, n * ri) - cross(about_y(ang_vel[j].xyz), n * -rj));
        }
        let mj = body[j].x;
        var p = pairs[mati * params.nmat + (kind[j] & 0xffffu)];
        // A bond's w is its share of the pair's strength (below 1 for a joint; 0 unbonded).
        if bonded {
            p.breaking_force *= st.w;
            p.fs0 *= st.w;
        }
        let c = contact(n, touch - dist, v_rel, ri * rj / touch, mi * mj / (mi + mj), p, in_plane(st.xyz), bonded,
                        dashpot_of(e), dt);
        f += c.force;
        h += vec3<f32>(c.heat_damping, c.heat_friction, c.heat_breakage);
        if DASHPOT {
            dashpot[e] = c.dashpot;
        }
        if ROTATION {
            t += cross(n * ri, c.shear);
        }
        state[e] = vec4<f32>(c.spring, select(0.0, st.w, c.bonded));
        if c.broke != 0u && i < j {
            // Breakage events are few: append (step, i, j, kind); the host sorts them.
            let k = atomicAdd(&counters[C_EVENTS], 1u);
            if k < params.max_events {
                events[k] = vec4<u32>(atomicLoad(&counters[C_STEP]), i, j, c.broke);
            }
        }
    }
    force[i] = vec4<f32>(f, 0.0);
    if ROTATION {
        torque[i] = vec4<f32>(t, 0.0);
    }
    // Each row books half of every pair's heat.
    book(HEAT_CONTACT_DAMPING, i, 0.5 * h.x);
    book(HEAT_FRICTION, i, 0.5 * h.y);
    book(HEAT_BREAKAGE, i, 0.5 * h.z);
}

fn dashpot_of(e: u32) -> f32 {
    if DASHPOT {
        return dashpot[e];
    }
    return 0.0;
}

// Heat of the unbonded contact of row entry e (i with j at offset d, its image sliding by
// `slide` under Lees–Edwards shear) that opened this step; clears its dashpot force.
fn opened_heat(i: u32, j: u32, e: u32, d: vec3<f32>, shear: vec3<f32>, slide: f32) -> vec3<f32> {
    let ri = origin[i].w;
    let rj = origin[j].w;
    let n = d / length(d);
    var v_rel = vel[i].xyz - vel[j].xyz;
    v_rel.x += slide;
    if ROTATION {
        v_rel = v_rel + (cross(ang_vel[i].xyz, n * ri) - cross(ang_vel[j].xyz, n * -rj));
    }
    let p = pairs[(kind[i] & 0xffffu) * params.nmat + (kind[j] & 0xffffu)];
    let fd = contact_opened(p, ri * rj / (ri + rj), shear, dashpot_of(e), n, v_rel, params.dt);
    if DASHPOT {
        dashpot[e] = 0.0;
    }
    return vec3<f32>(fd.y, fd.x, 0.0);
}

// Adds x to particle i's ledger lane `slot` (nothing when the plan has no such lane).
fn book(slot: u32, i: u32, x: f32) {
    if slot != HEAT_OFF && x != 0.0 {
        let k = ledger_index(i, slot, params.n);
        heat[k] = ledger_add(heat[k], x, params.one);
    }
}
