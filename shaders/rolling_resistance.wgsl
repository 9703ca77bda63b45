// The `rolling_resistance` stage on the GPU, the cdt model (constant directional torque): one
// invocation per particle walks its own neighbour row and the walls, and adds to its torque
// −μ_r·R_eff·Fn·ω̂_t for each contact, capped at I_eff·|ω_t|/dt (`cdt_torque` in
// engine/src/physics/rolling_resistance.rs, line for line, in f32): each pair is evaluated from
// both rows with exactly opposite inputs, so no float atomics. Runs once per slab of rows, after
// wall_forces, before integrate. CPU twin: engine/src/backend/cpu/rolling_resistance.rs.

// The rolling resistance coefficient μ_r, set for this pipeline only.
override ROLLING_MU: f32 = 0.0;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> origin: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> disp: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> kind: array<u32>;
@group(0) @binding(5) var<storage, read> row_len: array<u32>;
@group(0) @binding(6) var<storage, read> other: array<u32>;
@group(0) @binding(7) var<storage, read> pairs: array<Pair>;
@group(0) @binding(8) var<storage, read> ang_vel: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> torque: array<vec4<f32>>;
@group(0) @binding(10) var<uniform> slab: Slab;
@group(0) @binding(11) var<storage, read> walls: array<Wall>;
@group(0) @binding(12) var<storage, read> wall_pairs: array<Pair>;

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
    let start = local * params.cap;
    let end = start + row_len[i];
    for (var e = start; e < end; e++) {
        let j = other[e];
        // Both parts of the position differ little between neighbours: subtract each first.
        let d = (origin[j].xyz - oi) + (disp[j].xyz - ui);
        let rj = origin[j].w;
        let touch = ri + rj;
        let dist2 = dot(d, d);
        if dist2 >= touch * touch {
            continue;
        }
        let dist = sqrt(dist2);
        let r_eff = ri * rj / touch;
        let p = pairs[mati * params.nmat + (kind[j] & 0xffffu)];
        let ij = 0.4 * body[j].x * rj * rj;
        t += cdt_torque(d / dist, wi - ang_vel[j].xyz, r_eff, normal_force(p, r_eff, touch - dist),
                        pair_inertia(ii, ij), dt);
    }
    for (var w = 0u; w < params.nw; w++) {
        let ng = wall_normal_and_gap(walls[w], oi, ui);
        let overlap = ri - ng.w;
        if overlap <= 0.0 {
            continue;
        }
        let p = wall_pairs[w * params.nmat + mati];
        t += cdt_torque(-ng.xyz, wi, ri, normal_force(p, ri, overlap), ii, dt);
    }
    torque[i] = vec4<f32>(torque[i].xyz + t, 0.0);
}
