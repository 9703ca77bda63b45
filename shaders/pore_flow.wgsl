// The `pore_flow` stage on the GPU (f32): pore density flow coupled into the step. The
// network's topology (tetrahedra, pores, throats, each element's corners) is built on the host
// and uploaded; each step the device follows the elements and moves the fluid:
//
// - `pore_bonds` (per bond edge, one dispatch per slab of rows): whether each bond that crossed
//   a throat's face at the build still holds (its row entry's w ≠ 0), as the CPU's
//   `contacts.find(i, j)` sees it.
// - `pore_geometry` (per pore): its volume (Σ over its tetrahedra of tetrahedron − sphere
//   sectors, kept above VOLUME_FLOOR of the tetrahedra) and volume-weighted centre.
// - `throat_conductance` (per throat): the Poiseuille-type conductance of the face's opening,
//   capped by the pores' thickness, times the cement and permeability factors, plus the cubic
//   law of each broken bond across it.
// - `pore_stable_step` (per pore): the flow's stable step V/(K_f·Σg) of each free pore, its
//   minimum over the batch into a counter (the host sizes the sub-steps with it).
// - `pore_pressure` and `pore_mass`, once per sub-step (and `pore_pressure` once more after
//   the last): pressures from the excess masses, then each pore gathering its own row of throats.
// - `pore_forces` (per element): p·∂V/∂x of each (tetrahedron, corner) in the element's own
//   row, added to the force lane before integration.
// - `pore_drift` (per element, once per batch): how far the elements have moved since the
//   network was built, so the host rebuilds it when the CPU would.
//
// Each pore keeps its excess mass e, the mass it gained since the upload plus its excess at the
// upload (m − ρ0·V then), not m: in f32 the small changes of a nearly incompressible fluid
// would be lost against m. Its pressure p = K_f·(e − ρ0·(V − V0))/(ρ0·(V_h + V − V0)), V0 its
// volume at the upload as this file computes it and V_h the host's (f64, rounded): it sees only
// the change of the volume as this same code measures it (its f32 bias cancels). Even so, in a
// steady flow a pore's net inflow per sub-step is far under the ulp of its excess and the same
// every sub-step: rounded away, the same mass would be lost every sub-step while the reservoirs
// book the full flux (2.8e-3 of the throughput of a column at 1 MPa with a 1 kPa head). Each
// pore keeps what its updates rounded away (`excess_carry`, two-sum), adds it to its next
// increment, and the download adds it back. No float atomics: both pores of a throat compute the
// same g·Δp, so what one loses the other gains (to f32 round-off), and each element sums its own
// row.
// CPU twins: effects/pore_flow/network.rs (`refresh`), effects/pore_flow/flow.rs (`substep`),
// effects/pore_flow/pressure_forces.rs, run by effects/pore_flow/cpu/mod.rs. With the heat field on, the
// kernels of pore_heat.wgsl (appended to this file) replace `pore_pressure` and `pore_mass`.

struct PoreParams {
    bulk_modulus: f32,
    density: f32,
    viscosity: f32,
    // Sub-step h (s).
    h: f32,
    pores: u32,
    throats: u32,
    elements: u32,
    bond_edges: u32,
    cement_factor: f32,
    crack_aperture: f32,
    volume_floor: f32,
    // 1.0, opaque to the shader compiler (ledger_add).
    one: f32,
}

// A throat: its two pores, its face's three corners, the edges of the face bonded at the build
// (bit e: the edge opposite corner e) and the index of the first one's flag in `bond_alive`,
// and the harmonic mean of its corners' permeability factors.
struct Throat {
    a: u32,
    b: u32,
    c0: u32,
    c1: u32,
    c2: u32,
    bits: u32,
    first_edge: u32,
    factor: f32,
}

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

// w + inc as a sum and its rounding error (two-sum: exact whatever the magnitudes; each step
// multiplied by `pp.one`, which no real-arithmetic rewrite can cancel, as in ledger_add).
fn carried_sum(w: f32, inc: f32) -> vec2<f32> {
    let s = (w + inc) * pp.one;
    let b = (s - w) * pp.one;
    let err = (w - (s - b) * pp.one) * pp.one + (inc - b) * pp.one;
    return vec2<f32>(s, err);
}

// The pore's volume for its equation of state: the host's at the upload plus the change this
// code measured since. The device's own volume (a tetrahedron less four sphere sectors in f32)
// is off by up to ~1e-5 of itself, which at 1 MPa and K_f = 1e7 is ~10 Pa of pressure: as much
// as the head across a pore in a slow flow. Its change is not (the same code's error cancels).
fn eos_volume(p: u32) -> f32 {
    return volume_host[p] + (volume[p] - volume0[p]);
}

// x_j − x_i from the two parts of the positions (each subtracted first: they differ little).
fn between(i: u32, j: u32) -> vec3<f32> {
    return (origin[j].xyz - origin[i].xyz) + (disp[j].xyz - disp[i].xyz);
}

fn position(i: u32) -> vec3<f32> {
    return origin[i].xyz + disp[i].xyz;
}

// Solid angle at a of the triangle b, c, d given as u = b − a, v = c − a, w = d − a
// (Van Oosterom–Strackee; geometry.rs `solid_angle`).
fn solid_angle(u: vec3<f32>, v: vec3<f32>, w: vec3<f32>) -> f32 {
    let lu = length(u);
    let lv = length(v);
    let lw = length(w);
    let num = abs(dot(u, cross(v, w)));
    let den = lu * lv * lw + dot(u, v) * lw + dot(u, w) * lv + dot(v, w) * lu;
    return 2.0 * atan2(num, den);
}

// Angle between the edges u and v (geometry.rs `angle`).
fn angle(u: vec3<f32>, v: vec3<f32>) -> f32 {
    return atan2(length(cross(u, v)), dot(u, v));
}

@compute @workgroup_size(64)
fn pore_bonds(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = invocation(gid, groups);
    if k >= pp.bond_edges {
        return;
    }
    let ij = bond_edges[k];
    let i = ij.x;
    if i < slab.first || i >= slab.first + slab.count {
        return;
    }
    let local = i - slab.first;
    var alive = 0u;
    for (var e = local; e < row_end(local, row_len[i], slab.count); e += slab.count) {
        if other[e] == ij.y {
            alive = select(0u, 1u, state[e].w != 0.0);
            break;
        }
    }
    bond_alive[k] = alive;
}

@compute @workgroup_size(64)
fn pore_geometry(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    var empty = 0.0;
    var full = 0.0;
    var c = vec3<f32>(0.0);
    for (var k = pore_tet_start[p]; k < pore_tet_start[p + 1u]; k++) {
        let v = tets[pore_tets[k]];
        // Edges from each corner, so the volume and every solid angle come from differences.
        let e01 = between(v.x, v.y);
        let e02 = between(v.x, v.z);
        let e03 = between(v.x, v.w);
        let e12 = between(v.y, v.z);
        let e13 = between(v.y, v.w);
        let e23 = between(v.z, v.w);
        let vol = abs(dot(e03, cross(e13, e23))) / 6.0;
        let r = vec4<f32>(origin[v.x].w, origin[v.y].w, origin[v.z].w, origin[v.w].w);
        // Each sector at most the tetrahedron (geometry.rs `sectors_volume`).
        let sectors = min(solid_angle(e01, e02, e03) * r.x * r.x * r.x / 3.0, vol)
            + min(solid_angle(e12, e13, -e01) * r.y * r.y * r.y / 3.0, vol)
            + min(solid_angle(e23, -e02, -e12) * r.z * r.z * r.z / 3.0, vol)
            + min(solid_angle(-e03, -e13, -e23) * r.w * r.w * r.w / 3.0, vol);
        empty += vol - sectors;
        full += vol;
        // The corners' mean, relative to the first corner (its coordinate added last).
        c += (position(v.x) + 0.25 * (e01 + e02 + e03)) * vol;
    }
    if full > 0.0 {
        centre[p] = vec4<f32>(c / full, 0.0);
    } else {
        let v = tets[pore_tets[pore_tet_start[p]]];
        centre[p] = vec4<f32>(position(v.x) + 0.25 * (between(v.x, v.y) + between(v.x, v.z) + between(v.x, v.w)), 0.0);
    }
    volume[p] = max(empty, pp.volume_floor * full);
}

// Parallel-plate (cubic-law) conductance w³·b/(12 μ l) of a crack (geometry.rs `cubic_law`).
fn cubic_law(w: f32, b: f32, l: f32) -> f32 {
    return w * w * w * b / (12.0 * pp.viscosity * l);
}

@compute @workgroup_size(64)
fn throat_conductance(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = invocation(gid, groups);
    if t >= pp.throats {
        return;
    }
    let th = throats[t];
    var f = array<u32, 3>(th.c0, th.c1, th.c2);
    let r = vec3<f32>(origin[th.c0].w, origin[th.c1].w, origin[th.c2].w);
    // The opening: the face less the three circle sectors (geometry.rs `opening`).
    let e01 = between(th.c0, th.c1);
    let e02 = between(th.c0, th.c2);
    let e12 = between(th.c1, th.c2);
    let face = 0.5 * length(cross(e01, e02));
    let th0 = angle(e01, e02);
    let th1 = angle(e12, -e01);
    let th2 = angle(-e02, -e12);
    let sectors = 0.5 * (th0 * r.x * r.x + th1 * r.y * r.y + th2 * r.z * r.z);
    let perimeter = th0 * r.x + th1 * r.y + th2 * r.z;
    let area = max(face - sectors, 0.0);
    let mean_r = (r.x + r.y + r.z) / 3.0;
    let len = max(length(centre[th.a].xyz - centre[th.b].xyz), 0.1 * mean_r);
    var cracked = false;
    var crack_g = 0.0;
    var edge = th.first_edge;
    for (var e = 0u; e < 3u; e++) {
        if (th.bits & (1u << e)) == 0u {
            continue;
        }
        if bond_alive[edge] == 0u {
            cracked = true;
            let i = f[(e + 1u) % 3u];
            let j = f[(e + 2u) % 3u];
            let ri = origin[i].w;
            let rj = origin[j].w;
            let gap = length(between(i, j)) - ri - rj;
            let w = max(gap, pp.crack_aperture * mean_r);
            crack_g += cubic_law(w, min(ri, rj), len);
        }
        edge++;
    }
    var factor = th.factor;
    if th.bits != 0u && !cracked {
        factor *= pp.cement_factor;
    }
    // Poiseuille within the pores' thickness across the face (geometry.rs `poiseuille_within`).
    var g = 0.0;
    if area > 0.0 && perimeter > 0.0 {
        let thickness = 3.0 * min(volume[th.a], volume[th.b]) / max(face, 1e-37);
        let rh = min(area / perimeter, thickness);
        g = area * rh * rh / (2.0 * pp.viscosity * len);
    }
    conductance[t] = g * factor + crack_g;
}

@compute @workgroup_size(64)
fn pore_stable_step(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores || boundary[p].z > 0.5 {
        return;
    }
    var g = 0.0;
    for (var e = row_start[p]; e < row_start[p + 1u]; e++) {
        g += conductance[row[e]];
    }
    if g > 0.0 {
        // Positive f32s order like their bits.
        atomicMin(&counters[C_PORE_STEP], bitcast<u32>(volume[p] / (pp.bulk_modulus * g)));
    }
}

@compute @workgroup_size(64)
fn pore_pressure(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    let grown = pp.density * (volume[p] - volume0[p]);
    let v = eos_volume(p);
    let bc = boundary[p];
    if bc.z > 0.5 {
        // Held: the excess that gives the fixed pressure at the current volume; what the
        // pore had is its excess plus its carry.
        let held = grown + pp.density * v * bc.x / pp.bulk_modulus;
        supplied[p] = ledger_add(supplied[p], (held - excess[p]) - excess_carry[p], pp.one);
        excess_carry[p] = 0.0;
        excess[p] = held;
    }
    pressure[p] = pp.bulk_modulus * (excess[p] - grown) / (pp.density * v);
}

@compute @workgroup_size(64)
fn pore_mass(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let p = invocation(gid, groups);
    if p >= pp.pores {
        return;
    }
    let own = pressure[p];
    var inflow = 0.0;
    for (var e = row_start[p]; e < row_start[p + 1u]; e++) {
        let t = row[e];
        let th = throats[t];
        let other_pore = select(th.a, th.b, th.a == p);
        inflow += conductance[t] * (pressure[other_pore] - own);
    }
    let source = boundary[p].y;
    let added = carried_sum(excess[p], pp.density * pp.h * (inflow + source) + excess_carry[p]);
    excess[p] = added.x;
    excess_carry[p] = added.y;
    if source != 0.0 {
        supplied[p] = ledger_add(supplied[p], pp.density * pp.h * source, pp.one);
    }
}

// The corners of a tetrahedron listed from corner c by an even permutation
// (pressure_forces.rs `EVEN`).
fn even(c: u32, v: vec4<u32>) -> vec4<u32> {
    switch c {
        case 0u: { return v; }
        case 1u: { return vec4<u32>(v.y, v.x, v.w, v.z); }
        case 2u: { return vec4<u32>(v.z, v.w, v.x, v.y); }
        default: { return vec4<u32>(v.w, v.z, v.y, v.x); }
    }
}

@compute @workgroup_size(64)
fn pore_forces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= pp.elements {
        return;
    }
    var f = vec3<f32>(0.0);
    for (var k = elem_start[i]; k < elem_start[i + 1u]; k++) {
        let corner = elem_corners[k];
        let t = corner / 4u;
        let p = pressure[tet_pore[t]];
        if p != 0.0 {
            // ∂V/∂x of this corner: (x1 − x3) × (x2 − x3) / 6 in the even order from it.
            let e = even(corner % 4u, tets[t]);
            let grad = cross(between(e.w, e.y), between(e.w, e.z)) / 6.0;
            f += grad * (p * tet_sign[t]);
        }
    }
    force[i] += vec4<f32>(f, 0.0);
}

@compute @workgroup_size(64)
fn pore_drift(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= pp.elements {
        return;
    }
    let d = disp[i].xyz - pore_built[i].xyz;
    atomicMax(&counters[C_PORE_DRIFT], bitcast<u32>(dot(d, d)));
}
