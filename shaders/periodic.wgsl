// The `periodic` stage on the GPU, right after the move: an element that left the cell comes
// back through the opposite face (its displacement shifted by the span, its crossings counted,
// so that a download shifts its displacement's origin on the host). Under Lees–Edwards shear
// (SHEAR) an element crossing a z face also moves along x by the images' offset after this
// step's advance and changes its x velocity by their slide, continuing as the image it was;
// the x shifts it took add up in its crossings' w (f32 bits) for the host. CPU twin:
// effects/periodic/cpu.rs.

// Bindings: generated from this stage's list in engine/src/effects/periodic/gpu.rs.

@compute @workgroup_size(64)
fn periodic(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    // A clump's members move with its centre, which the clumps stage wraps.
    if i >= params.n || (kind[i] & CLUMPED) != 0u {
        return;
    }
    var x = origin[i].xyz + disp[i].xyz;
    var u = disp[i].xyz;
    var k = crossings[i];
    if SHEAR {
        let cells = sheared_crossing(x.z);
        if cells != 0.0 {
            let shift = vec3<f32>(cells * params.shear.y, 0.0, cells * params.period.z);
            x += shift;
            u += shift;
            k.z += i32(cells);
            k.w = bitcast<i32>(bitcast<f32>(k.w) + shift.x);
            vel[i].x += cells * params.shear.z;
        }
    }
    for (var a = 0; a < 3; a++) {
        let span = params.period[a];
        if span > 0.0 {
            let lo = params.period_lo[a];
            if x[a] < lo {
                u[a] += span;
                k[a] += 1;
            } else if x[a] >= lo + span {
                u[a] -= span;
                k[a] -= 1;
            }
        }
    }
    disp[i] = vec4<f32>(u, 0.0);
    crossings[i] = k;
}
