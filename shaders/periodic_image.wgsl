// A periodic cell's arithmetic for the stages that measure pairs or bin positions (rows,
// cell_list, contact_forces, guard, neighbours, rolling_resistance, parallel_bond, diffusion): `params.period` holds each axis's span (0 on an
// axis that does not repeat), `params.period_inv` its inverse (0 there too) and
// `params.period_lo` its lower face. CPU twin: effects/periodic/setting.rs and the cell list's
// wrap (neighbours/cell_list.rs).

// The separation d through the nearest image (unchanged without PERIODIC). Under Lees–Edwards
// shear the image k cells up along z sits k·offset further along x.
fn nearest_image(d: vec3<f32>) -> vec3<f32> {
    if !PERIODIC {
        return d;
    }
    var s = d;
    if SHEAR {
        s.x -= image_rows(d) * params.shear.x;
    }
    return s - params.period.xyz * round(s * params.period_inv.xyz);
}

// Under Lees–Edwards shear, the cells k along z between j and the image of j nearest i, for
// the separation d = x_j − x_i: what the pair's relative velocity v_i − v_j gains along x is
// k·γ̇·L_z (`params.shear.z`), the image k cells down moving that much slower than j.
fn image_rows(d: vec3<f32>) -> f32 {
    return round(d.z * params.period_inv.z);
}

// What the relative velocity v_i − v_j of the pair at separation d (before the nearest image)
// gains along x through the sliding images (0 without SHEAR).
fn image_slide(d: vec3<f32>) -> f32 {
    if !SHEAR {
        return 0.0;
    }
    return image_rows(d) * params.shear.z;
}

// Cells along a periodic axis: whole cells of at least params.cell tiling its span.
fn periodic_cells() -> vec3<i32> {
    return max(vec3<i32>(1), vec3<i32>(floor(params.period.xyz / params.cell)));
}

// The cell of position x: on a periodic axis counted from its lower face in cells that tile
// the span, and wrapped; elsewhere as cell_of.
fn cell_at(x: vec3<f32>) -> vec3<i32> {
    var c = cell_of(x, params.cell);
    if PERIODIC {
        let n = periodic_cells();
        let w = params.period.xyz / vec3<f32>(n);
        for (var k = 0; k < 3; k++) {
            if params.period[k] > 0.0 {
                let at = i32(floor((x[k] - params.period_lo[k]) / w[k]));
                c[k] = ((at % n[k]) + n[k]) % n[k];
            }
        }
    }
    return c;
}

// A neighbouring cell c, wrapped round the periodic axes.
fn wrap_cell(c: vec3<i32>) -> vec3<i32> {
    var w = c;
    if PERIODIC {
        let n = periodic_cells();
        for (var k = 0; k < 3; k++) {
            if params.period[k] > 0.0 {
                w[k] = ((c[k] % n[k]) + n[k]) % n[k];
            }
        }
    }
    return w;
}

// Under Lees–Edwards shear, the x cell about which an element at x looks in the layer of cells
// cz (unwrapped): reached up through the top face, that layer's elements meet x through their
// images one cell up, offset further along x, so the search centres on x less the offset (plus
// it through the bottom face); x's own cell elsewhere. CPU twin: the cell list's whole rows
// across a z face (neighbours/cell_list.rs), which find the same pairs.
fn sheared_layer_x(x: vec3<f32>, cz: i32) -> i32 {
    let nz = periodic_cells().z;
    var k = 0.0;
    if cz >= nz {
        k = 1.0;
    } else if cz < 0 {
        k = -1.0;
    }
    return cell_at(x - vec3<f32>(k * params.shear.x, 0.0, 0.0)).x;
}

// Under Lees–Edwards shear, the cells an element at height z crossed this step: +1 having left
// through the bottom face (it comes in at the top as the image one cell down), −1 through the
// top, 0 inside. The periodic and clumps stages add that many cells' shift (z by L_z, x by the
// offset) and slide to what crossed.
fn sheared_crossing(z: f32) -> f32 {
    let lo = params.period_lo.z;
    if z < lo {
        return 1.0;
    }
    if z >= lo + params.period.z {
        return -1.0;
    }
    return 0.0;
}
