// A periodic cell's arithmetic for the stages that measure pairs or bin positions (rows,
// cell_list, contact_forces, guard, neighbours, rolling_resistance, parallel_bond, diffusion): `params.period` holds each axis's span (0 on an
// axis that does not repeat), `params.period_inv` its inverse (0 there too) and
// `params.period_lo` its lower face. CPU twin: effects/periodic/setting.rs and the cell list's
// wrap (neighbours/cell_list.rs).

// The separation d through the nearest image (unchanged without PERIODIC).
fn nearest_image(d: vec3<f32>) -> vec3<f32> {
    if !PERIODIC {
        return d;
    }
    return d - params.period.xyz * round(d * params.period_inv.xyz);
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
