// The scalar-diffusion core the field stages share (engine/src/diffusion.rs): element i's
// inflow Q_i = own_i + Σ_j G_ij·(u_j − u_i) over its row and its ΣG_i, nothing through a
// sealed end. Prepended to a field stage's file, whose bindings hold the core's (params,
// origin, disp, row_len, other, state, slab) and which declares the field's terms: `field_value(j)`,
// `field_sealed(j)` and `field_pair(i, j, ri, rj, dist, bonded)` (WGSL resolves names across
// the module, so the core calls them before they are written).

const FIELD_FREE: u32 = 0u;
const FIELD_FIXED: u32 = 1u;
const FIELD_SEALED: u32 = 2u;

struct Exchange {
    q: f32,
    g: f32,
}

// Row entries of particle i, its `local` index in the slab; `own` is the element's own term.
fn row_exchange(i: u32, local: u32, ui: f32, own: Exchange) -> Exchange {
    var x = own;
    if field_sealed(i) {
        return x;
    }
    let oi = origin[i].xyz;
    let ri = origin[i].w;
    let di = disp[i].xyz;
    let end = row_end(local, row_len[i], slab.count);
    for (var e = local; e < end; e += slab.count) {
        let j = other[e];
        if field_sealed(j) {
            continue;
        }
        let d = nearest_image((origin[j].xyz - oi) + (disp[j].xyz - di));
        let g = field_pair(i, j, ri, origin[j].w, length(d), state[e].w != 0.0);
        x.q += g * (field_value(j) - ui);
        x.g += g;
    }
    return x;
}
