// An exclusive prefix sum of u32s in place, one level at a time: each workgroup scans 256
// elements and leaves their total in the level above; once the level above is scanned, its
// sums are added back. Integer sums: the result does not depend on the order of anything.
// Used for the cell list's bucket starts (cell_list.wgsl).

struct ScanLevel {
    // Where this level starts in `data`, how long it is, and where its block sums go
    // (NO_SUMS for the top level, which one workgroup scans whole).
    start: u32,
    len: u32,
    sums: u32,
    pad: u32,
}

const NO_SUMS: u32 = 0xffffffffu;

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

var<workgroup> block: array<u32, 256>;

@compute @workgroup_size(256)
fn scan_blocks(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) li: u32) {
    let g = wg.x + wg.y * groups.x;
    let k = g * 256u + li;
    var v = 0u;
    if k < level.len {
        v = data[level.start + k];
    }
    block[li] = v;
    workgroupBarrier();
    for (var s = 1u; s < 256u; s <<= 1u) {
        var add = 0u;
        if li >= s {
            add = block[li - s];
        }
        workgroupBarrier();
        block[li] += add;
        workgroupBarrier();
    }
    if k < level.len {
        data[level.start + k] = block[li] - v;
    }
    if li == 255u && level.sums != NO_SUMS {
        data[level.sums + g] = block[255];
    }
}

@compute @workgroup_size(256)
fn add_block_sums(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                  @builtin(local_invocation_index) li: u32) {
    let g = wg.x + wg.y * groups.x;
    let k = g * 256u + li;
    if k < level.len {
        data[level.start + k] += data[level.sums + g];
    }
}
