// The `integrate` stage on the GPU: gravity, MatDEM's viscous damping (semi-implicit), Cundall's
// local damping, blocked degrees of freedom and leapfrog integration; rotation (and its
// accumulated angle) when the plan has it. Also counts the step. CPU twin: backend/cpu/integrate.rs.
// Its own pass only when a force stage runs between the wall pass and it, or without walls;
// otherwise the wall pass integrates each particle as it finishes it (wall_forces.wgsl).

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

@compute @workgroup_size(64)
fn integrate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if i == 0u {
        count_step();
    }
    if i >= params.n {
        return;
    }
    var t = vec3<f32>(0.0);
    if ROTATION {
        t = torque[i].xyz;
    }
    integrate_particle(i, force[i].xyz, t);
}

// The step counter, advanced once a step by particle 0's invocation.
fn count_step() {
    atomicAdd(&counters[C_STEP], 1u);
}

// Moves particle i under its summed force f and torque t (the wall pass calls this for its own
// particle when no force stage comes between them: wall_forces.wgsl).
fn integrate_particle(i: u32, f: vec3<f32>, t: vec3<f32>) {
    if CLUMPS && (kind[i] & CLUMPED) != 0u {
        // Its clump moves it (the `clumps` stage, next).
        return;
    }
    let dt = params.dt;
    let mi = body[i].x;
    // Half the viscous damping coefficient times dt over m (semi-implicit form).
    let a = 0.5 * body[i].y * dt;
    let v0 = vel[i].xyz;
    var f_total = f + params.gravity.xyz * mi;
    // Heat of the damping this step (booked in the ledger's damping lane).
    var h = 0.0;
    if LOCAL {
        h = params.local_damping * dot(abs(f_total), abs(v0)) * dt;
        // Cundall's local damping: −α·|F|·sign(v) per component (sign(0) = 0).
        f_total = f_total - params.local_damping * abs(f_total) * sign(v0);
    }
    let accel = f_total / mi;
    var v1 = v0 + accel * dt;
    if VISCOUS {
        // (v0·(1 − a) + accel·dt)/(1 + a), written as v0 plus a change that f32 rounds
        // relative to itself: 1 − a would round a damping rate of a ~ 1e-5 by ~1e-2, and the
        // heat booked, c·|v̄|²·dt, would no longer be the energy the damping removed.
        v1 = v0 + (accel * dt - 2.0 * a * v0) / (1.0 + a);
    }
    let fixed = kind[i] >> 24u;
    if (fixed & 1u) != 0u {
        v1.x = v0.x;
    }
    if (fixed & 2u) != 0u {
        v1.y = v0.y;
    }
    if (fixed & 4u) != 0u {
        v1.z = v0.z;
    }
    if VISCOUS {
        // c·|v̄|²·dt: exactly the work the semi-implicit damping removes.
        let vm = 0.5 * (v0 + v1);
        h += body[i].y * mi * dot(vm, vm) * dt;
    }
    vel[i] = vec4<f32>(v1, 0.0);
    disp[i] = vec4<f32>(disp[i].xyz + v1 * dt, 0.0);
    if ROTATION {
        let r = origin[i].w;
        let inertia = 0.4 * mi * r * r;
        let w0 = ang_vel[i].xyz;
        var w1 = w0 + t / inertia * dt;
        if VISCOUS {
            w1 = w0 + (t / inertia * dt - 2.0 * a * w0) / (1.0 + a);
        }
        // A fixed rotation (dof bits 3..5: rx, ry, rz) keeps its component.
        if (fixed & 8u) != 0u {
            w1.x = w0.x;
        }
        if (fixed & 16u) != 0u {
            w1.y = w0.y;
        }
        if (fixed & 32u) != 0u {
            w1.z = w0.z;
        }
        ang_vel[i] = vec4<f32>(w1, 0.0);
        angle[i] = vec4<f32>(angle[i].xyz + w1 * dt, 0.0);
        if VISCOUS {
            let wm = 0.5 * (w0 + w1);
            h += body[i].y * inertia * dot(wm, wm) * dt;
        }
    }
    if HEAT_DAMPING != HEAT_OFF && h != 0.0 {
        let k = ledger_index(i, HEAT_DAMPING, params.n);
        heat[k] = ledger_add(heat[k], h, params.one);
    }
}
