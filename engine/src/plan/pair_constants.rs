//! The constants of a pair (two elements, or an element and a rigid wall) from their materials,
//! which a plan tabulates per material pair.

use crate::materials::Material;
use crate::physics::contact_law::PairParams;
use crate::physics::restitution::{hertz_damping_alpha, linear_damping_ratio};

/// Two elements in contact: springs in series, the smaller strength, the smaller restitution.
pub fn pair_params(a: &Material, b: &Material) -> PairParams {
    let series = |x: f64, y: f64| if x + y > 0.0 { x * y / (x + y) } else { 0.0 };
    // Each element carries twice the lattice spring, so identical elements give back kn.
    let kn = series(2.0 * a.kn, 2.0 * b.kn);
    let ks = series(2.0 * a.ks, 2.0 * b.ks);
    let e_star = 1.0 / ((1.0 - a.poisson.powi(2)) / a.young + (1.0 - b.poisson.powi(2)) / b.young);
    let ga = a.young / (2.0 * (1.0 + a.poisson));
    let gb = b.young / (2.0 * (1.0 + b.poisson));
    let g_star = 1.0 / ((2.0 - a.poisson) / ga + (2.0 - b.poisson) / gb);
    let e = a.restitution.min(b.restitution);
    PairParams {
        kn,
        ks,
        breaking_force: kn * a.xb.min(b.xb),
        fs0: a.fs0.min(b.fs0),
        mu: a.mu_p.min(b.mu_p),
        e_star,
        g_star,
        zeta: linear_damping_ratio(e),
        alpha: hertz_damping_alpha(e),
    }
}

/// An element against a rigid wall: the element's own springs, E* = E/(1−ν²).
pub fn rigid_wall_params(a: &Material) -> PairParams {
    let g = a.young / (2.0 * (1.0 + a.poisson));
    PairParams {
        kn: 2.0 * a.kn,
        ks: 2.0 * a.ks,
        breaking_force: 0.0,
        fs0: 0.0,
        mu: a.mu_p,
        e_star: a.young / (1.0 - a.poisson * a.poisson),
        g_star: g / (2.0 - a.poisson),
        zeta: linear_damping_ratio(a.restitution),
        alpha: hertz_damping_alpha(a.restitution),
    }
}
