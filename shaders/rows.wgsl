// The `neighbours` stage on the GPU, second half of a row build: each particle builds its own
// neighbour row from the cell list, with the content and order of the CPU's rebuild: every j != i
// closer than r_i + r_j + skin, plus every pair bonded in the old row however far, sorted by j,
// each with the state and dashpot force the old row held for it (zero when new), as the CPU carries
// the whole PairState. Runs once per slab of rows.
//
// Rows are written in place, so the build runs twice: a counting pass (`count_rows`, WRITE_ROWS
// off) finds the longest new row and the rows with more set states than MAX_CARRY, and the
// writing pass (`build_rows`, WRITE_ROWS on) does nothing unless every row fits its slots; the
// host then builds the rows instead.
// CPU twin: rebuild in backend/cpu/neighbours.rs.

override WRITE_ROWS: bool = false;

// Set states (contacts, bonds) a row may carry across a build.
const MAX_CARRY: u32 = 64u;

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

// The counting pass's findings per workgroup (zero at the start of a dispatch): each workgroup
// sends one maximum and one count to the device-wide counters, not one per particle.
var<workgroup> group_longest: atomic<u32>;
var<workgroup> group_crowded: atomic<u32>;

// The counting pass (WRITE_ROWS off): the longest new row and the rows that carry too much.
@compute @workgroup_size(64)
fn count_rows(@builtin(global_invocation_id) gid: vec3<u32>,
              @builtin(num_workgroups) groups: vec3<u32>,
              @builtin(local_invocation_index) li: u32) {
    let local = invocation(gid, groups);
    if local < slab.count {
        let found = build_row(local);
        atomicMax(&group_longest, found.x);
        atomicAdd(&group_crowded, found.y);
    }
    workgroupBarrier();
    if li == 0u {
        atomicMax(&counters[C_LONGEST], atomicLoad(&group_longest));
        let crowded = atomicLoad(&group_crowded);
        if crowded != 0u {
            atomicAdd(&counters[C_CROWDED], crowded);
        }
    }
}

// The writing pass (WRITE_ROWS on): nothing unless the counting pass found every row fits.
@compute @workgroup_size(64)
fn build_rows(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = invocation(gid, groups);
    if local >= slab.count {
        return;
    }
    if atomicLoad(&counters[C_LONGEST]) > params.cap || atomicLoad(&counters[C_CROWDED]) != 0u {
        return;
    }
    build_row(local);
}

// Builds the row of the slab's particle `local`: with WRITE_ROWS off only counts it, and
// returns its length and whether it has more set states than MAX_CARRY (1) or not (0).
fn build_row(local: u32) -> vec2<u32> {
    let i = slab.first + local;
    let cap = params.cap;
    // The old row's set states, in j order (the old row is sorted). A state is set when any
    // of it is non-zero, its dashpot force included: a head-on contact has no shear spring
    // but its last dashpot force is still owed to the next step's trapezoid.
    var carry_j: array<u32, MAX_CARRY>;
    var carry_s: array<vec4<f32>, MAX_CARRY>;
    var carry_d: array<f32, MAX_CARRY>;
    var carry_r: array<vec4<f32>, MAX_CARRY>;
    var carried = 0u;
    var crowded = false;
    let old_len = row_len[i];
    for (var k = 0u; k < old_len; k++) {
        let s = state[row_slot(local, k, slab.count)];
        var fd = 0.0;
        if DASHPOT {
            fd = dashpot[row_slot(local, k, slab.count)];
        }
        var sr = vec4<f32>(0.0);
        if ROLLING_SPRING {
            sr = rolling[row_slot(local, k, slab.count)];
        }
        if any(s != vec4<f32>(0.0)) || fd != 0.0 || any(sr != vec4<f32>(0.0)) {
            if carried < MAX_CARRY {
                carry_j[carried] = other[row_slot(local, k, slab.count)];
                carry_s[carried] = s;
                carry_d[carried] = fd;
                carry_r[carried] = sr;
                carried++;
            } else {
                crowded = true;
            }
        }
    }
    // Bonded pairs stay, however far apart.
    var len = 0u;
    for (var m = 0u; m < carried; m++) {
        if carry_s[m].w != 0.0 {
            if WRITE_ROWS {
                other[row_slot(local, len, slab.count)] = carry_j[m];
            }
            len++;
        }
    }
    let oi = origin[i].xyz;
    let ui = disp[i].xyz;
    let ri = origin[i].w;
    let c = cell_at(oi + ui);
    // A killed element looks for no neighbour (and is skipped by everyone else's search below).
    let alive = (kind[i] & KILLED) == 0u;
    // Cells that hash to one bucket are visited once, so no j is seen twice.
    var seen: array<u32, 27>;
    var buckets = 0u;
    // A 2D model's centres share one layer of cells: its neighbours are in the 9 cells about i's.
    let y_reach = select(1, 0, PLANAR);
    for (var z = -1; z <= 1; z++) {
        // Under Lees–Edwards shear a layer of cells reached round a z face holds the images
        // shifted along x by the offset: look about i's x less that shift there.
        var layer = c;
        if SHEAR {
            layer.x = sheared_layer_x(oi + ui, c.z + z);
        }
        for (var y = -y_reach; y <= y_reach; y++) {
            for (var x = -1; x <= 1; x++) {
                if !alive {
                    continue;
                }
                let b = bucket_of(wrap_cell(layer + vec3<i32>(x, y, z)), params.buckets);
                var again = false;
                for (var q = 0u; q < buckets; q++) {
                    again = again || seen[q] == b;
                }
                if again {
                    continue;
                }
                seen[buckets] = b;
                buckets++;
                let end = cell_start[b + 1u];
                for (var s = cell_start[b]; s < end; s++) {
                    let j = cell_items[s];
                    if j == i || (kind[j] & KILLED) != 0u {
                        continue;
                    }
                    // Members of one clump never touch: it is rigid.
                    if CLUMPS && (kind[i] & CLUMPED) != 0u && clump_of[i] == clump_of[j] {
                        continue;
                    }
                    // Both parts of the position differ little between neighbours: subtract each first.
                    let d = nearest_image((origin[j].xyz - oi) + (disp[j].xyz - ui));
                    let cut = ri + origin[j].w + params.skin;
                    if dot(d, d) >= cut * cut {
                        continue;
                    }
                    var kept = false;
                    for (var m = 0u; m < carried; m++) {
                        kept = kept || (carry_j[m] == j && carry_s[m].w != 0.0);
                    }
                    if kept {
                        continue;
                    }
                    if WRITE_ROWS && len < cap {
                        other[row_slot(local, len, slab.count)] = j;
                    }
                    len++;
                }
            }
        }
    }
    if !WRITE_ROWS {
        return vec2<u32>(len, select(0u, 1u, crowded));
    }
    // Sort by j (insertion: rows are short), then give each entry its old state.
    for (var k = 1u; k < len; k++) {
        let j = other[row_slot(local, k, slab.count)];
        var h = k;
        while h > 0u && other[row_slot(local, h - 1u, slab.count)] > j {
            other[row_slot(local, h, slab.count)] = other[row_slot(local, h - 1u, slab.count)];
            h--;
        }
        other[row_slot(local, h, slab.count)] = j;
    }
    var m = 0u;
    for (var k = 0u; k < len; k++) {
        let j = other[row_slot(local, k, slab.count)];
        // Both lists are sorted by j: walk them together.
        while m < carried && carry_j[m] < j {
            m++;
        }
        var s = vec4<f32>(0.0);
        var fd = 0.0;
        var sr = vec4<f32>(0.0);
        if m < carried && carry_j[m] == j {
            s = carry_s[m];
            fd = carry_d[m];
            sr = carry_r[m];
        }
        state[row_slot(local, k, slab.count)] = s;
        if DASHPOT {
            dashpot[row_slot(local, k, slab.count)] = fd;
        }
        if ROLLING_SPRING {
            rolling[row_slot(local, k, slab.count)] = sr;
        }
    }
    row_len[i] = len;
    built[i] = vec4<f32>(ui, 0.0);
    return vec2<u32>(len, 0u);
}
