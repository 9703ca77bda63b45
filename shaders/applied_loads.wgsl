// The `applied_loads` stage on the GPU, a force stage after the others (and before buoyancy,
// whose drag reads their sum) and `integrate`: each loaded element adds its applied force to its
// own force lane and, when the plan has torques (APPLIED_TORQUE), its applied torque to its own
// torque lane. Killed elements feel nothing. No atomics. Their work is booked on the host, from
// the positions and angles a download brings back (effects/applied_loads/lanes.rs).
// CPU twin: effects/applied_loads/cpu.rs.

// Some element carries a torque: the torque lane is written (it exists only with rotation).
override APPLIED_TORQUE: bool = false;

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

@compute @workgroup_size(64)
fn applied_loads(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n || (kind[i] & KILLED) != 0u {
        return;
    }
    force[i] = vec4<f32>(force[i].xyz + applied_force[i].xyz, force[i].w);
    if APPLIED_TORQUE {
        torque[i] = vec4<f32>(torque[i].xyz + applied_torque[i].xyz, torque[i].w);
    }
}
