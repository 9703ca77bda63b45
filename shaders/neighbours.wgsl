// The `neighbours` stage on the GPU: how far the particles have drifted since the neighbour rows
// were built, and how fast the fastest moves, so the host knows when the rows must be rebuilt
// (drift over half the skin) and how many steps it may run before it must look again. Non-negative
// f32s order like their bits, so an integer atomicMax finds the largest. Each workgroup finds its
// own largest first, in workgroup memory, and only that goes to the device-wide counter: a
// maximum is the same in any order, and one atomic on one word per workgroup instead of per
// particle keeps the millions of a large scene from queueing on it. CPU twin:
// neighbours::is_stale in backend/cpu/neighbours.rs.

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

var<workgroup> group_drift: atomic<u32>;
var<workgroup> group_speed: atomic<u32>;

@compute @workgroup_size(64)
fn measure_drift(@builtin(global_invocation_id) gid: vec3<u32>,
                 @builtin(num_workgroups) groups: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let i = gid.x + gid.y * groups.x * 64u;
    // Workgroup memory starts at zero, the smallest value either measure takes.
    if i < params.n {
        // In a periodic cell an element that crossed a face has drifted by its move, not the span.
        let d = nearest_image(disp[i].xyz - built[i].xyz);
        atomicMax(&group_drift, bitcast<u32>(dot(d, d)));
        let v = vel[i].xyz;
        atomicMax(&group_speed, bitcast<u32>(dot(v, v)));
    }
    workgroupBarrier();
    if li == 0u {
        atomicMax(&counters[C_DRIFT], atomicLoad(&group_drift));
        atomicMax(&counters[C_SPEED], atomicLoad(&group_speed));
    }
}
