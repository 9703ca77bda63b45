// The `neighbours` stage on the GPU, first half of a row build: the cell list the rows are built
// from, without host bounds: cells hashed into a power-of-two table. Each particle counts itself
// into its bucket (integer atomics), the counts are scanned into bucket starts (scan.wgsl), and
// each particle takes a place in its bucket. The order inside a bucket depends on the atomics;
// harmless, as every row is sorted after it is collected (rows.wgsl). CPU twin: find_pairs in
// backend/cpu/neighbours.rs.

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

fn bucket_of_particle(i: u32) -> u32 {
    return bucket_of(cell_at(origin[i].xyz + disp[i].xyz), params.buckets);
}

@compute @workgroup_size(64)
fn bin_particles(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    atomicAdd(&bucket_count[bucket_of_particle(i)], 1u);
}

// Counting down leaves every count at zero again, ready for the next build.
@compute @workgroup_size(64)
fn fill_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    let b = bucket_of_particle(i);
    let k = atomicSub(&bucket_count[b], 1u) - 1u;
    cell_items[cell_start[b] + k] = i;
}
