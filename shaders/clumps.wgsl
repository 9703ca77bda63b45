// The `clumps` stage on the GPU, right after the move (which leaves the members alone): one
// invocation per clump sums its members' forces and torques about its centre in member order,
// advances the body (leapfrog translation; angular momentum kicked by the torque, the
// orientation turned by the free rotation split into exact turns about the principal axes) and
// places its members where the body carries them; in a periodic cell it wraps the centre
// (the periodic stage's part for clumps). CPU twin: effects/clumps/cpu.rs.

// Bindings: generated from this stage's list in engine/src/effects/clumps/gpu.rs.

struct ClumpBody {
    // The centre at upload (xyz, the f64 rounded to f32) and the mass (w).
    pos0: vec4<f32>,
    // The centre's move since the upload (xyz): a member's position is its origin plus its
    // displacement, so both parts stay small where they are subtracted.
    dpos: vec4<f32>,
    vel: vec4<f32>,
    // Angular momentum about the centre, world frame.
    ang_mom: vec4<f32>,
    // Orientation, principal frame to world, as a quaternion (x, y, z, w).
    q: vec4<f32>,
    // Principal moments of inertia.
    inertia: vec4<f32>,
}

fn q_mul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}

// v turned by q.
fn q_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

// v turned back by q.
fn q_unrotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    return q_rotate(vec4<f32>(-q.xyz, q.w), v);
}

// The angular velocity (world) of a body turned by q with world angular momentum l.
fn clump_ang_vel(q: vec4<f32>, l: vec3<f32>, inertia: vec3<f32>) -> vec3<f32> {
    return q_rotate(q, q_unrotate(q, l) / inertia);
}

// ½·Σ L_k²/I_k.
fn clump_rot_energy(q: vec4<f32>, l: vec3<f32>, inertia: vec3<f32>) -> f32 {
    let lb = q_unrotate(q, l);
    return 0.5 * dot(lb * lb, 1.0 / inertia);
}

// A step of the free rotation: turns about the principal axes x½, y½, z, y½, x½, each exact.
fn free_rotation(q0: vec4<f32>, l: vec3<f32>, inertia: vec3<f32>, dt: f32) -> vec4<f32> {
    var q = q0;
    var lb = q_unrotate(q, l);
    let axes = array<u32, 5>(0u, 1u, 2u, 1u, 0u);
    let share = array<f32, 5>(0.5, 0.5, 1.0, 0.5, 0.5);
    for (var k = 0u; k < 5u; k++) {
        let a = axes[k];
        let angle = lb[a] / inertia[a] * share[k] * dt;
        var e = vec3<f32>(0.0);
        e[a] = 1.0;
        let turn = vec4<f32>(e * sin(0.5 * angle), cos(0.5 * angle));
        q = q_mul(q, turn);
        lb = q_unrotate(turn, lb);
    }
    return normalize(q);
}

@compute @workgroup_size(64)
fn clumps(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = gid.x + gid.y * groups.x * 64u;
    if c + 1u >= arrayLength(&clump_start) {
        return;
    }
    var b = clump_bodies[c];
    let mass = b.pos0.w;
    let dt = params.dt;
    let first = clump_start[c];
    let end = clump_start[c + 1u];
    var f = params.gravity.xyz * mass;
    var t = vec3<f32>(0.0);
    // Σ c_i = Σ (c_i/m_i)·m_i, the members' dashpots summed.
    var c_sum = 0.0;
    for (var k = first; k < end; k++) {
        let j = bitcast<u32>(clump_members[k].w);
        let arm = (origin[j].xyz - b.pos0.xyz) + (disp[j].xyz - b.dpos.xyz);
        f += force[j].xyz;
        t += cross(arm, force[j].xyz) + torque[j].xyz;
        c_sum += body[j].y * body[j].x;
    }
    if PLANAR {
        // A 2D clump is held in y and in spin about x and z, as a 2D model's elements are.
        f.y = 0.0;
        t.x = 0.0;
        t.z = 0.0;
    }
    let q0 = b.q;
    let v0 = b.vel.xyz;
    let l0 = b.ang_mom.xyz;
    let w0 = clump_ang_vel(q0, l0, b.inertia.xyz);
    var h = 0.0;
    if LOCAL {
        h = params.local_damping * (dot(abs(f), abs(v0)) + dot(abs(t), abs(w0))) * dt;
        f = f - params.local_damping * abs(f) * sign(v0);
        t = t - params.local_damping * abs(t) * sign(w0);
    }
    // Semi-implicit viscous damping, written as in integrate.wgsl (a change f32 rounds
    // relative to itself).
    let a = 0.5 * c_sum / mass * dt;
    let v1 = v0 + (f / mass * dt - 2.0 * a * v0) / (1.0 + a);
    let l1 = l0 + (t * dt - 2.0 * a * l0) / (1.0 + a);
    if VISCOUS {
        let vm = 0.5 * (v0 + v1);
        h += c_sum * dot(vm, vm) * dt + c_sum / mass * 2.0 * clump_rot_energy(q0, 0.5 * (l0 + l1), b.inertia.xyz) * dt;
    }
    b.vel = vec4<f32>(v1, 0.0);
    b.dpos = vec4<f32>(b.dpos.xyz + v1 * dt, 0.0);
    if PERIODIC {
        // A clump leaves the cell whole: its centre comes back through the opposite face and
        // its members follow (the periodic stage leaves them alone; they may reach out of the
        // cell, where pairs meet through the nearest image). The host squares their
        // displacement origins at a download.
        var centre = b.pos0.xyz + b.dpos.xyz;
        if SHEAR {
            // Through a z face under Lees–Edwards shear it continues as the image it was:
            // shifted along x by the offset and slower or faster by the slide (periodic.wgsl).
            let cells = sheared_crossing(centre.z);
            if cells != 0.0 {
                let shift = vec3<f32>(cells * params.shear.y, 0.0, cells * params.period.z);
                centre += shift;
                b.dpos = vec4<f32>(b.dpos.xyz + shift, 0.0);
                b.vel.x += cells * params.shear.z;
            }
        }
        for (var a = 0; a < 3; a++) {
            let span = params.period[a];
            if span > 0.0 {
                let lo = params.period_lo[a];
                if centre[a] < lo {
                    b.dpos[a] += span;
                } else if centre[a] >= lo + span {
                    b.dpos[a] -= span;
                }
            }
        }
    }
    b.ang_mom = vec4<f32>(l1, 0.0);
    b.q = free_rotation(q0, l1, b.inertia.xyz, dt);
    clump_bodies[c] = b;
    let w1 = clump_ang_vel(b.q, l1, b.inertia.xyz);
    for (var k = first; k < end; k++) {
        let m = clump_members[k];
        let j = bitcast<u32>(m.w);
        let arm = q_rotate(b.q, m.xyz);
        disp[j] = vec4<f32>((b.pos0.xyz - origin[j].xyz) + b.dpos.xyz + arm, 0.0);
        // b.vel: v1, or v1 and the slide of a crossing under Lees–Edwards shear.
        vel[j] = vec4<f32>(b.vel.xyz + cross(w1, arm), 0.0);
        ang_vel[j] = vec4<f32>(w1, 0.0);
        angle[j] = vec4<f32>(angle[j].xyz + w1 * dt, 0.0);
    }
    if HEAT_DAMPING != HEAT_OFF && h != 0.0 && end > first {
        let k = ledger_index(bitcast<u32>(clump_members[first].w), HEAT_DAMPING, params.n);
        heat[k] = ledger_add(heat[k], h, params.one);
    }
}
