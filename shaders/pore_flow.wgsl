// The `pore_flow` stage's flow update on the GPU (f32): one explicit sub-step of the pore
// fluid, in two passes of one invocation per pore.
//
// Each pore keeps its excess mass e = m − ρ0·V (V its volume, fixed while the device steps),
// not m: in f32 the small changes of a nearly incompressible fluid would be lost against m.
//
// - `pore_pressure`: a pore held at a pressure gets the excess of that pressure; every pore's
//   pressure follows from its excess, p = K_f·e/(ρ0·V) (= K_f·(m/(ρ0·V) − 1)).
// - `pore_mass`: each pore gathers its own row of throats, inflow = Σ_t g_t·(p_other − p_self),
//   and adds ρ0·h·(inflow + source) to its own excess. No atomics: both pores of a throat
//   compute the same g·Δp, so the mass one loses the other gains (to f32 round-off).
//
// The network's geometry (volumes, conductances) and its rebuilds stay on the host; the
// guard's stable step V/(K_f·Σg) is the host's too. CPU twin: pores/flow.rs (`substep`), run
// by backend/cpu/pore_flow.rs.

struct Fluid {
    bulk_modulus: f32,
    density: f32,
    // Sub-step h (s).
    h: f32,
    pores: u32,
}

@group(0) @binding(0) var<uniform> fluid: Fluid;
// Per pore: (volume, fixed pressure, volumetric source, 1 when held at the pressure else 0).
@group(0) @binding(1) var<storage, read> pore: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> excess: array<f32>;
@group(0) @binding(3) var<storage, read_write> pressure: array<f32>;
// CSR rows of throats per pore.
@group(0) @binding(4) var<storage, read> row_start: array<u32>;
@group(0) @binding(5) var<storage, read> row: array<u32>;
// Per throat: (pore a, pore b).
@group(0) @binding(6) var<storage, read> ends: array<vec2<u32>>;
@group(0) @binding(7) var<storage, read> conductance: array<f32>;

fn pore_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

@compute @workgroup_size(64)
fn pore_pressure(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = pore_index(gid, groups);
    if p >= fluid.pores {
        return;
    }
    let v = pore[p].x;
    if pore[p].w > 0.5 {
        excess[p] = fluid.density * v * pore[p].y / fluid.bulk_modulus;
    }
    pressure[p] = fluid.bulk_modulus * excess[p] / (fluid.density * v);
}

@compute @workgroup_size(64)
fn pore_mass(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = pore_index(gid, groups);
    if p >= fluid.pores {
        return;
    }
    let own = pressure[p];
    var inflow = 0.0;
    for (var e = row_start[p]; e < row_start[p + 1u]; e++) {
        let t = row[e];
        let ab = ends[t];
        let other = select(ab.x, ab.y, ab.x == p);
        inflow += conductance[t] * (pressure[other] - own);
    }
    excess[p] += fluid.density * fluid.h * (inflow + pore[p].z);
}
