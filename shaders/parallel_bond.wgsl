// The `parallel_bond` stage on the GPU: parallel bonds (Potyondy & Cundall 2004) in parallel
// with the linear contacts. One invocation per particle walks its own row of bonds, updates each
// bond in the bond's canonical orientation (lower id first, so both rows compute the same
// numbers and take the same breaking decision), stores the new state in its own row entry and
// adds its side's force and torque to what contact_forces and wall_forces summed: no float
// atomics. `update` in engine/src/effects/parallel_bond/physics.rs, line for line, in f32; CPU twin:
// engine/src/effects/parallel_bond/cpu.rs. Runs after wall_forces, before integrate.

// The bonds' parameters (ParallelBondParams), and the count of particles.
struct BondParams {
    lambda: f32,
    e_star: f32,
    k_ratio: f32,
    sigma_c: f32,
    cohesion: f32,
    tan_phi: f32,
    n: u32,
    pad: u32,
}

// One bond end (BondState): the shear force and normal force (tension positive) on the higher
// id, its bending moment and twisting moment, and its status (0 broken, 1 intact, 2 new).
struct Bond {
    shear_normal: vec4<f32>,
    bending_twist: vec4<f32>,
    status: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

const BOND_BROKEN: u32 = 0u;
const BOND_INTACT: u32 = 1u;
const BOND_NEW: u32 = 2u;

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

// The force and torque one bond puts on its lower (f0, t0) and higher (f1, t1) end, and how it
// broke this step (0 none, 1 tension, 2 shear) with the energy it held.
struct BondLoad {
    f0: vec3<f32>,
    t0: vec3<f32>,
    f1: vec3<f32>,
    t1: vec3<f32>,
    broke: u32,
    energy: f32,
}

@compute @workgroup_size(64)
fn parallel_bond(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= bp.n {
        return;
    }
    var f = vec3<f32>(0.0);
    var t = vec3<f32>(0.0);
    var freed = 0.0;
    for (var e = row_start[i]; e < row_start[i + 1u]; e++) {
        var b = bonds[e];
        if b.status == BOND_BROKEN {
            continue;
        }
        let j = other[e];
        let lo = min(i, j);
        let hi = max(i, j);
        let load = update(lo, hi, &b);
        bonds[e] = b;
        if i == lo {
            f += load.f0;
            t += load.t0;
        } else {
            f += load.f1;
            t += load.t1;
        }
        if load.broke != 0u {
            freed += 0.5 * load.energy;
            if i == lo {
                // Breakage events are few: append (step, i, j, kind); the host sorts them.
                let k = atomicAdd(&counters[C_EVENTS], 1u);
                if k < params.max_events {
                    events[k] = vec4<u32>(atomicLoad(&counters[C_STEP]), lo, hi, load.broke);
                }
            }
        }
    }
    force[i] = vec4<f32>(force[i].xyz + f, 0.0);
    torque[i] = vec4<f32>(torque[i].xyz + t, 0.0);
    if HEAT_BREAKAGE != HEAT_OFF && freed != 0.0 {
        let k = ledger_index(i, HEAT_BREAKAGE, params.n);
        heat[k] = ledger_add(heat[k], freed, params.one);
    }
}

// Advances the bond between lo < hi by a step (see `update` on the CPU).
fn update(lo: u32, hi: u32, b: ptr<function, Bond>) -> BondLoad {
    var out: BondLoad;
    out.broke = 0u;
    let r0 = origin[lo].w;
    let r1 = origin[hi].w;
    // Both parts of the position differ little between the two ends: subtract each first.
    let raw = (origin[hi].xyz - origin[lo].xyz) + (disp[hi].xyz - disp[lo].xyz);
    let d = nearest_image(raw);
    let dist = length(d);
    let n = d / dist;
    let rb = bp.lambda * min(r0, r1);
    let rb2 = rb * rb;
    let area = 3.14159265 * rb2;
    let inertia = 0.25 * 3.14159265 * rb2 * rb2;
    let polar = 2.0 * inertia;
    let kn = bp.e_star / (r0 + r1);
    let ks = kn / bp.k_ratio;
    let half_gap = 0.5 * (dist - r0 - r1);
    let arm0 = n * (r0 + half_gap);
    let arm1 = n * -(r1 + half_gap);
    var shear = rotate_into_plane((*b).shear_normal.xyz, n);
    var normal = (*b).shear_normal.w;
    var bending = rotate_into_plane((*b).bending_twist.xyz, n);
    var twist = (*b).bending_twist.w;
    if (*b).status == BOND_NEW {
        (*b).status = BOND_INTACT;
    } else {
        let w0 = ang_vel[lo].xyz;
        let w1 = ang_vel[hi].xyz;
        // hi's image moves slower along x by its slide under Lees–Edwards shear (0 without).
        let v_hi = vel[hi].xyz - vec3<f32>(image_slide(raw), 0.0, 0.0);
        let v = (v_hi + cross(w1, arm1)) - (vel[lo].xyz + cross(w0, arm0));
        let dd = v * params.dt;
        let dn = dot(dd, n);
        let ds = dd - n * dn;
        let dth = (w1 - w0) * params.dt;
        let dtw = dot(dth, n);
        let db = dth - n * dtw;
        normal += kn * area * dn;
        shear -= ds * (ks * area);
        twist -= ks * polar * dtw;
        bending -= db * (kn * inertia);
    }
    let sigma = normal / area + length(bending) * rb / inertia;
    let tau = length(shear) / area + abs(twist) * rb / polar;
    let strength = bp.cohesion - normal / area * bp.tan_phi;
    if sigma > bp.sigma_c {
        out.broke = 1u;
    } else if tau > strength {
        out.broke = 2u;
    }
    if out.broke != 0u {
        out.energy = normal * normal / (2.0 * kn * area) + dot(bending, bending) / (2.0 * kn * inertia)
            + dot(shear, shear) / (2.0 * ks * area) + twist * twist / (2.0 * ks * polar);
        (*b).shear_normal = vec4<f32>(0.0);
        (*b).bending_twist = vec4<f32>(0.0);
        (*b).status = BOND_BROKEN;
        return out;
    }
    (*b).shear_normal = vec4<f32>(shear, normal);
    (*b).bending_twist = vec4<f32>(bending, twist);
    let f1 = shear - n * normal;
    let m = n * twist + bending;
    out.f0 = -f1;
    out.f1 = f1;
    out.t0 = cross(arm0, -f1) - m;
    out.t1 = cross(arm1, f1) + m;
    return out;
}
