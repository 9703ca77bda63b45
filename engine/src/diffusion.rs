//! The scalar-diffusion core that the field stages share (heat conduction and moisture,
//! paper 003 §3.3 eq. 3): a value u on every element, exchanged with its neighbours over the
//! contact rows, Q_i = own_i + Σ_j G_ij·(u_j − u_i), and one forward-Euler sub-step
//! u_i ← u_i + Δt·Q_i/C_i. What differs between the fields is only the pair conductance G (a
//! constriction for heat, a contact area for water) and the element's own term (a heat source;
//! evaporation towards an ambient water content): each field says those through [`Exchange`].
//!
//! Each element sums its own row in row order and writes only its own entries: no atomics, the
//! same bits on any thread count. A fixed element keeps its value; a sealed (insulated)
//! element exchanges nothing with any neighbour, and a neighbour exchanges nothing with it.
//! The backends' passes call [`substep`] (the CPU) or mirror it (the WGSL twins).

use crate::effects::periodic::setting::Separations;
use crate::physics::Vec3;
use crate::state::contacts::Contacts;

/// [`crate::effects::conduction::lanes::ThermalLanes::mode`] and the moisture lanes' mode: the element
/// exchanges with its neighbours.
pub const FREE: u8 = 0;
/// Held at its value (a boundary at a fixed temperature or water content).
pub const FIXED: u8 = 1;
/// Exchanges nothing with any neighbour (insulated for heat, sealed for water).
pub const SEALED: u8 = 2;

/// What one field exchanges: the element's own term and the pair conductance.
pub trait Exchange: Sync {
    /// Element `i`'s own inflow at value `u` (per second, in the field's unit times the
    /// capacity's) and the conductance it adds to ΣG (for the stability limit C/ΣG).
    fn own(&self, i: usize, u: f64) -> (f64, f64);
    /// The conductance of the pair (i, j) at centre distance `dist`; symmetric in i and j,
    /// so what one element loses the other gains.
    fn pair(&self, i: usize, j: usize, dist: f64, bonded: bool) -> f64;
}

/// One element's inflow Q_i and ΣG_i over its row (nothing through a sealed end).
#[inline(always)]
pub fn row_exchange<X: Exchange>(
    x: &X,
    pos: &[Vec3],
    sep: &Separations,
    c: &Contacts,
    u: &[f64],
    mode: &[u8],
    i: usize,
) -> (f64, f64) {
    let (mut q, mut sum) = x.own(i, u[i]);
    if mode[i] != SEALED {
        for e in c.row(i) {
            let j = c.other[e] as usize;
            if mode[j] == SEALED {
                continue;
            }
            // Through the nearest image in a periodic cell.
            let d = sep.between(pos, i, j).norm();
            let g = x.pair(i, j, d, c.state[e].bonded);
            q += g * (u[j] - u[i]);
            sum += g;
        }
    }
    (q, sum)
}

/// One forward-Euler sub-step of elements `range`: `next[k]` and `sum[k]` get element
/// `range.start + k`'s new value and ΣG.
#[inline]
pub fn substep<X: Exchange>(
    x: &X,
    pos: &[Vec3],
    sep: &Separations,
    c: &Contacts,
    u: &[f64],
    capacity: &[f64],
    mode: &[u8],
    dt: f64,
    range: std::ops::Range<usize>,
    next: &mut [f64],
    sum: &mut [f64],
) {
    for i in range.clone() {
        let k = i - range.start;
        let (q, g) = row_exchange(x, pos, sep, c, u, mode, i);
        sum[k] = g;
        next[k] = if mode[i] == FIXED { u[i] } else { u[i] + dt * q / capacity[i] };
    }
}

/// The first element whose forward-Euler sub-step `dt` is not below its limit C_i/ΣG_i, as
/// (element, ΣG, limit); fixed elements and elements without exchange are skipped. The rows
/// must be built.
pub fn unstable_element<X: Exchange>(
    x: &X,
    pos: &[Vec3],
    sep: &Separations,
    c: &Contacts,
    u: &[f64],
    capacity: &[f64],
    mode: &[u8],
    dt: f64,
) -> Option<(usize, f64, f64)> {
    (0..pos.len()).filter(|&i| mode[i] != FIXED).find_map(|i| {
        let (_, g) = row_exchange(x, pos, sep, c, u, mode, i);
        let limit = capacity[i] / g;
        (g > 0.0 && dt >= limit).then_some((i, g, limit))
    })
}
