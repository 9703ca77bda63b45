// The `neighbours` stage on the GPU: how far the particles have drifted since the neighbour rows
// were built, and how fast the fastest moves, so the host knows when the rows must be rebuilt
// (drift over half the skin) and how many steps it may run before it must look again. Non-negative
// f32s order like their bits, so an integer atomicMax finds the largest. CPU twin:
// neighbours::is_stale in backend/cpu/neighbours.rs.

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

@compute @workgroup_size(64)
fn measure_drift(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if i >= params.n {
        return;
    }
    let d = disp[i].xyz - built[i].xyz;
    atomicMax(&counters[C_DRIFT], bitcast<u32>(dot(d, d)));
    let v = vel[i].xyz;
    atomicMax(&counters[C_SPEED], bitcast<u32>(dot(v, v)));
}
