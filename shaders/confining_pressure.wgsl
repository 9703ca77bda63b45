// The `confining_pressure` stage on the GPU, a force stage after `applied_loads` and before
// `buoyancy` and `integrate`: a triaxial cell's membrane. The side of the sample between the two
// platens is cut into bands × sectors cells (effects/confining_pressure/physics.rs); each step
// `confine_clear` empties the cells, `confine_mark` raises each cell's reach ρ + r to its grains'
// largest (an integer atomic max on the f32's bits, which order as the values do for values ≥ 0),
// `confine_pick` lowers the cell's id to the lowest grain at that reach, `confine_share` gives
// each empty cell's patch to the touched cell beside it whose grain reaches farthest (a count
// per cell), and `confine_apply` pushes each picked grain towards the axis with
// σ·(ρ + r)·Δθ·Δz times its cell's patches (a 2D model: σ·t·Δz on the grains of each side). A cell is three words: the reach's bits, the id, the
// shares; the apply pass runs over the cells, not the grains. Integer atomics only: the picks and shares, and so the forces, are the same whatever
// order the invocations run in. Killed elements are in no cell.
// CPU twin: effects/confining_pressure/cpu.rs.

struct Confine {
    pressure: f32,
    cx: f32,
    cy: f32,
    bands: u32,
    sectors: u32,
    bottom: u32,
    top: u32,
    cells: u32,
    // A 2D model's plate thickness (PLANAR): the membrane is the two sides, left and right.
    thickness: f32,
}

const TAU: f32 = 6.28318530717959;
const HALF_TURN: f32 = 3.14159265358979;
const NO_GRAIN: u32 = 0xffffffffu;

// Bindings: generated from this stage's list in effects/confining_pressure/gpu.rs.

struct Place {
    cell: u32,
    reach: f32,
    out: vec2<f32>,
    // The cell's patch of membrane per unit reach, Δθ·Δz.
    area: f32,
}

// Where grain `i` sits against the membrane, with the platens where they stand this step.
fn membrane_place(i: u32) -> Place {
    let z0 = walls[confine.bottom].point.z + walls[confine.bottom].moved.z;
    let z1 = walls[confine.top].point.z + walls[confine.top].moved.z;
    let dz = (z1 - z0) / f32(confine.bands);
    let dtheta = TAU / f32(confine.sectors);
    let o = origin[i];
    let p = o.xyz + disp[i].xyz;
    let band_of = min(u32(max(floor((p.z - z0) / dz), 0.0)), confine.bands - 1u);
    if PLANAR {
        // Sector 0 left of the axis, 1 right; the patch t·Δz whatever the reach (area per
        // unit reach, as the 3D cells').
        let dx = p.x - confine.cx;
        let reach = abs(dx) + o.w;
        return Place(band_of * 2u + select(0u, 1u, dx >= 0.0), reach, vec2<f32>(sign(dx), 0.0),
                     confine.thickness * dz / reach);
    }
    let d = vec2<f32>(p.x - confine.cx, p.y - confine.cy);
    let rho = length(d);
    let band = band_of;
    let sector = min(u32(max(floor((atan2(d.y, d.x) + HALF_TURN) / dtheta), 0.0)), confine.sectors - 1u);
    var out = vec2<f32>(0.0, 0.0);
    if rho > 0.0 {
        out = d / rho;
    }
    return Place(band * confine.sectors + sector, rho + o.w, out, dtheta * dz);
}

@compute @workgroup_size(64)
fn confine_clear(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(gid, groups);
    if c >= confine.cells {
        return;
    }
    atomicStore(&cells[3u * c], 0u);
    atomicStore(&cells[3u * c + 1u], NO_GRAIN);
    atomicStore(&cells[3u * c + 2u], 0u);
}

@compute @workgroup_size(64)
fn confine_mark(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n || (kind[i] & KILLED) != 0u {
        return;
    }
    let p = membrane_place(i);
    atomicMax(&cells[3u * p.cell], bitcast<u32>(p.reach));
}

@compute @workgroup_size(64)
fn confine_pick(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n || (kind[i] & KILLED) != 0u {
        return;
    }
    let p = membrane_place(i);
    if bitcast<u32>(p.reach) == atomicLoad(&cells[3u * p.cell]) {
        atomicMin(&cells[3u * p.cell + 1u], i);
    }
}

// An empty cell's patch goes to the touched cell beside it whose grain reaches farthest: the
// sectors before and after it in its band, then the bands below and above (the first of
// equals; `Cells::beside` and `shares` in physics.rs).
@compute @workgroup_size(64)
fn confine_share(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(gid, groups);
    if c >= confine.cells || atomicLoad(&cells[3u * c + 1u]) != NO_GRAIN {
        return;
    }
    let s = confine.sectors;
    let band = c / s;
    let sector = c % s;
    var beside = array<u32, 4>(NO_GRAIN, NO_GRAIN, NO_GRAIN, NO_GRAIN);
    // A 2D model's two sides do not touch.
    if s > 1u && !PLANAR {
        beside[0] = band * s + (sector + s - 1u) % s;
    }
    if s > 2u && !PLANAR {
        beside[1] = band * s + (sector + 1u) % s;
    }
    if band > 0u {
        beside[2] = c - s;
    }
    if band + 1u < confine.bands {
        beside[3] = c + s;
    }
    var to = NO_GRAIN;
    var reach = 0u;
    for (var k = 0u; k < 4u; k++) {
        let n = beside[k];
        if n == NO_GRAIN || atomicLoad(&cells[3u * n + 1u]) == NO_GRAIN {
            continue;
        }
        let r = atomicLoad(&cells[3u * n]);
        if to == NO_GRAIN || r > reach {
            to = n;
            reach = r;
        }
    }
    if to != NO_GRAIN {
        atomicAdd(&cells[3u * to + 2u], 1u);
    }
}

// One invocation a cell: its grain, if any, pushed (a grain is in one cell: one writer a lane).
@compute @workgroup_size(64)
fn confine_apply(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = invocation(gid, groups);
    if c >= confine.cells {
        return;
    }
    let i = atomicLoad(&cells[3u * c + 1u]);
    if i == NO_GRAIN {
        return;
    }
    let p = membrane_place(i);
    let patches = f32(1u + atomicLoad(&cells[3u * c + 2u]));
    let f = -confine.pressure * p.reach * p.area * patches;
    force[i] = vec4<f32>(force[i].xy + p.out * f, force[i].z, force[i].w);
}
