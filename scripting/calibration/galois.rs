//! Finite fields GF(q), q = p^k, as addition and multiplication tables: what the
//! Rao–Hamming construction of orthogonal arrays needs. Element `e` stands for the
//! polynomial Σ dᵢ·xⁱ whose coefficients dᵢ are the base-p digits of `e`; products are
//! reduced modulo the first monic irreducible polynomial of degree k (found by search).

use super::{CalibrationError, Result};

/// The largest field built (an L-array of such a field has q² runs or more).
pub const MAX_ORDER: u32 = 64;

#[derive(Debug, Clone)]
pub struct Field {
    pub order: usize,
    add: Vec<u8>,
    mul: Vec<u8>,
}

impl Field {
    /// GF(q); refuses q that is not a prime power or exceeds [`MAX_ORDER`].
    pub fn new(q: u32) -> Result<Self> {
        let (p, k) = prime_power(q).ok_or_else(|| {
            CalibrationError::new(format!(
                "{q} levels: an orthogonal array of this construction needs a prime power number of levels \
                 (2, 3, 4, 5, 7, 8, 9, …) up to {MAX_ORDER}"
            ))
        })?;
        let modulus = irreducible(p, k);
        let q = q as usize;
        let mut add = vec![0u8; q * q];
        let mut mul = vec![0u8; q * q];
        for a in 0..q {
            for b in 0..q {
                let (da, db) = (digits(a, p, k), digits(b, p, k));
                let sum: Vec<u32> = da.iter().zip(&db).map(|(x, y)| (x + y) % p).collect();
                add[a * q + b] = undigits(&sum, p) as u8;
                mul[a * q + b] = undigits(&poly_mul_mod(&da, &db, &modulus, p), p) as u8;
            }
        }
        Ok(Field { order: q, add, mul })
    }

    #[inline]
    pub fn add(&self, a: u8, b: u8) -> u8 {
        self.add[a as usize * self.order + b as usize]
    }

    #[inline]
    pub fn mul(&self, a: u8, b: u8) -> u8 {
        self.mul[a as usize * self.order + b as usize]
    }
}

/// (p, k) with q = p^k, p prime, q ≤ MAX_ORDER.
pub fn prime_power(q: u32) -> Option<(u32, u32)> {
    if !(2..=MAX_ORDER).contains(&q) {
        return None;
    }
    let p = (2..=q).find(|d| q.is_multiple_of(*d))?;
    let (mut rest, mut k) = (q, 0);
    while rest.is_multiple_of(p) {
        rest /= p;
        k += 1;
    }
    (rest == 1).then_some((p, k))
}

fn digits(mut e: usize, p: u32, k: u32) -> Vec<u32> {
    (0..k)
        .map(|_| {
            let d = (e % p as usize) as u32;
            e /= p as usize;
            d
        })
        .collect()
}

fn undigits(d: &[u32], p: u32) -> usize {
    d.iter().rev().fold(0usize, |acc, &x| acc * p as usize + x as usize)
}

/// Remainder of `a` divided by the monic polynomial `m` (coefficients lowest first) mod p.
fn poly_rem(a: &[u32], m: &[u32], p: u32) -> Vec<u32> {
    let mut r: Vec<u32> = a.to_vec();
    let dm = m.len() - 1;
    while r.len() > dm {
        let lead = *r.last().unwrap_or(&0);
        let shift = r.len() - 1 - dm;
        if lead != 0 {
            for (i, &c) in m.iter().enumerate() {
                r[i + shift] = (r[i + shift] + p * p - lead * c % p) % p;
            }
        }
        r.pop();
    }
    r.resize(dm, 0);
    r
}

/// a·b mod m, all of degree < k = deg m.
fn poly_mul_mod(a: &[u32], b: &[u32], m: &[u32], p: u32) -> Vec<u32> {
    let mut prod = vec![0u32; a.len() + b.len()];
    for (i, &x) in a.iter().enumerate() {
        for (j, &y) in b.iter().enumerate() {
            prod[i + j] = (prod[i + j] + x * y) % p;
        }
    }
    poly_rem(&prod, m, p)
}

/// The first monic irreducible polynomial of degree k over GF(p) (coefficients lowest
/// first), by trial division with every monic polynomial of degree 1 … k/2.
fn irreducible(p: u32, k: u32) -> Vec<u32> {
    let monic = |deg: u32, n: usize| {
        let mut c = digits(n, p, deg);
        c.push(1);
        c
    };
    let count = |deg: u32| (p as usize).pow(deg);
    (0..count(k))
        .map(|n| monic(k, n))
        .find(|m| {
            (1..=k / 2).all(|deg| (0..count(deg)).all(|n| poly_rem(m, &monic(deg, n), p).iter().any(|&c| c != 0)))
        })
        .expect("an irreducible polynomial of every degree exists over every prime field")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prime_powers_are_recognised_and_others_refused() {
        assert_eq!(prime_power(25), Some((5, 2)));
        assert_eq!(prime_power(8), Some((2, 3)));
        assert_eq!(prime_power(7), Some((7, 1)));
        assert_eq!(prime_power(6), None);
        assert_eq!(prime_power(1), None);
        assert!(Field::new(6).unwrap_err().to_string().contains("prime power"));
    }

    #[test]
    fn every_nonzero_element_has_a_multiplicative_inverse_and_the_laws_hold() {
        for q in [2u32, 3, 4, 5, 7, 8, 9, 16, 25, 27, 32] {
            let f = Field::new(q).unwrap();
            let q = q as u8;
            for a in 1..q {
                assert_eq!((1..q).filter(|&b| f.mul(a, b) == 1).count(), 1, "GF({q}): {a} has no unique inverse");
            }
            for a in 0..q {
                assert_eq!(f.add(a, 0), a);
                assert_eq!(f.mul(a, 1), a);
                for b in 0..q {
                    assert_eq!(f.mul(a, b), f.mul(b, a));
                    for c in 0..q {
                        // Distributivity ties the two tables together.
                        assert_eq!(f.mul(a, f.add(b, c)), f.add(f.mul(a, b), f.mul(a, c)), "GF({q})");
                    }
                }
            }
        }
    }
}
