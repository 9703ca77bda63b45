//! Four f64 lanes, and vectors of them: the pair pass's arithmetic four pairs at a time.
//!
//! Each operation is written as four independent IEEE operations, which the compiler packs
//! into one SIMD instruction (two SSE2 or one AVX2 instruction); nothing is fused or
//! reordered, so every lane gives bit for bit what the same expression gives on scalars. The
//! vector operations keep nalgebra's operand order for the same reason (`dot` is
//! (x·x' + y·y') + z·z', `cross` the usual components), which the pair pass's bitwise test
//! holds them to.

use crate::physics::Vec3;
use std::array::from_fn;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Lanes per batch.
pub const LANES: usize = 4;

/// Four f64 lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct X4(pub [f64; LANES]);

/// A lane mask.
#[derive(Clone, Copy, Debug)]
pub struct M4(pub [bool; LANES]);

impl X4 {
    #[inline(always)]
    pub fn splat(x: f64) -> X4 {
        X4([x; LANES])
    }

    /// Each lane of `f(lane)`.
    #[inline(always)]
    pub fn lanes(f: impl FnMut(usize) -> f64) -> X4 {
        X4(from_fn(f))
    }

    #[inline(always)]
    pub fn sqrt(self) -> X4 {
        X4(self.0.map(f64::sqrt))
    }

    /// `f64::max` per lane (the scalar law's clamps).
    #[inline(always)]
    pub fn max(self, o: X4) -> X4 {
        X4(from_fn(|l| self.0[l].max(o.0[l])))
    }

    /// `f64::min` per lane.
    #[inline(always)]
    pub fn min(self, o: X4) -> X4 {
        X4(from_fn(|l| self.0[l].min(o.0[l])))
    }

    #[inline(always)]
    pub fn gt(self, o: X4) -> M4 {
        M4(from_fn(|l| self.0[l] > o.0[l]))
    }

    #[inline(always)]
    pub fn eq(self, o: X4) -> M4 {
        M4(from_fn(|l| self.0[l] == o.0[l]))
    }
}

impl M4 {
    /// `a` where the mask is set, `b` elsewhere.
    #[inline(always)]
    pub fn select(self, a: X4, b: X4) -> X4 {
        X4(from_fn(|l| if self.0[l] { a.0[l] } else { b.0[l] }))
    }

    /// [`select`](Self::select) for vectors.
    #[inline(always)]
    pub fn select_v<const P: bool>(self, a: V4<P>, b: V4<P>) -> V4<P> {
        let y = if P { a.y } else { self.select(a.y, b.y) };
        V4 { x: self.select(a.x, b.x), y, z: self.select(a.z, b.z) }
    }

    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().any(|&m| m)
    }
}

macro_rules! lane_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for X4 {
            type Output = X4;
            #[inline(always)]
            fn $method(self, o: X4) -> X4 {
                X4(from_fn(|l| self.0[l] $op o.0[l]))
            }
        }
    };
}
lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl Neg for X4 {
    type Output = X4;
    #[inline(always)]
    fn neg(self) -> X4 {
        X4(self.0.map(|x| -x))
    }
}

/// Four 3-vectors, one per lane, as three lanes of components. `P` (planar): every vector
/// lies in the x–z plane of a 2D model, its y lanes zero and never computed, so a 2D scene's
/// pairs pay for two components, not three; a planar operation gives the 3D one's bits (the
/// terms it skips are exact zeros) but for the sign of a zero result.
#[derive(Clone, Copy, Debug)]
pub struct V4<const P: bool = false> {
    pub x: X4,
    pub y: X4,
    pub z: X4,
}

impl<const P: bool> V4<P> {
    #[inline(always)]
    pub fn zeros() -> Self {
        let z = X4::splat(0.0);
        V4 { x: z, y: z, z }
    }

    /// Each lane's vector `f(lane)` (planar: its y is not read).
    #[inline(always)]
    pub fn lanes(mut f: impl FnMut(usize) -> Vec3) -> Self {
        let v: [Vec3; LANES] = from_fn(&mut f);
        let y = if P { X4::splat(0.0) } else { X4(from_fn(|l| v[l].y)) };
        V4 { x: X4(from_fn(|l| v[l].x)), y, z: X4(from_fn(|l| v[l].z)) }
    }

    /// Lane `l`'s vector.
    #[inline(always)]
    pub fn get(&self, l: usize) -> Vec3 {
        Vec3::new(self.x.0[l], self.y.0[l], self.z.0[l])
    }

    /// nalgebra's order: (x·x' + y·y') + z·z'.
    #[inline(always)]
    pub fn dot(&self, o: &Self) -> X4 {
        if P {
            self.x * o.x + self.z * o.z
        } else {
            self.x * o.x + self.y * o.y + self.z * o.z
        }
    }

    #[inline(always)]
    pub fn norm_squared(&self) -> X4 {
        self.dot(self)
    }

    /// `w × self`. Planar, `w` is a 2D model's spin about y (its x and z zero): the full cross
    /// product's x and z with its operations on those zeros' results, w_y·z − 0 and 0 − w_y·x,
    /// and no y.
    #[inline(always)]
    pub fn spun_by(&self, w: &V4) -> Self {
        if P {
            let zero = X4::splat(0.0);
            V4 { x: w.y * self.z - zero, y: zero, z: zero - w.y * self.x }
        } else {
            let c = w.cross(&V4 { x: self.x, y: self.y, z: self.z });
            V4 { x: c.x, y: c.y, z: c.z }
        }
    }
}

impl V4 {
    #[inline(always)]
    pub fn cross(&self, o: &V4) -> V4 {
        V4 { x: self.y * o.z - self.z * o.y, y: self.z * o.x - self.x * o.z, z: self.x * o.y - self.y * o.x }
    }
}

impl<const P: bool> Add for V4<P> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V4 { x: self.x + o.x, y: if P { self.y } else { self.y + o.y }, z: self.z + o.z }
    }
}

impl<const P: bool> Sub for V4<P> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V4 { x: self.x - o.x, y: if P { self.y } else { self.y - o.y }, z: self.z - o.z }
    }
}

/// Each component times the lane's scalar (nalgebra's `v * s`).
impl<const P: bool> Mul<X4> for V4<P> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: X4) -> Self {
        V4 { x: self.x * s, y: if P { self.y } else { self.y * s }, z: self.z * s }
    }
}

/// Each component divided by the lane's scalar (nalgebra's `v / s`: a division, not a
/// multiplication by the reciprocal).
impl<const P: bool> Div<X4> for V4<P> {
    type Output = Self;
    #[inline(always)]
    fn div(self, s: X4) -> Self {
        V4 { x: self.x / s, y: if P { self.y } else { self.y / s }, z: self.z / s }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lanes' vector operations give nalgebra's results bit for bit, on values whose
    /// roundings depend on the order of the operations.
    #[test]
    fn lane_vector_operations_match_nalgebra_bit_for_bit() {
        let a: [Vec3; LANES] =
            from_fn(|l| Vec3::new(0.1 + l as f64, -1e-17 * (l as f64 + 1.0), 3.3e5 / (l as f64 + 7.0)));
        let b: [Vec3; LANES] = from_fn(|l| Vec3::new(1.0 / 3.0 + l as f64, 7e16, -2.2 / (l as f64 + 1.5)));
        let s = X4::lanes(|l| 0.7 + l as f64 / 9.0);
        let (va, vb): (V4, V4) = (V4::lanes(|l| a[l]), V4::lanes(|l| b[l]));
        let bits = |v: Vec3| v.map(f64::to_bits);
        for l in 0..LANES {
            assert_eq!(va.dot(&vb).0[l].to_bits(), a[l].dot(&b[l]).to_bits());
            assert_eq!(va.norm_squared().0[l].to_bits(), a[l].norm_squared().to_bits());
            assert_eq!(bits(va.cross(&vb).get(l)), bits(a[l].cross(&b[l])));
            assert_eq!(bits((va * s).get(l)), bits(a[l] * s.0[l]));
            assert_eq!(bits((va / s).get(l)), bits(a[l] / s.0[l]));
            assert_eq!(bits((va - vb).get(l)), bits(a[l] - b[l]));
        }
    }
}
