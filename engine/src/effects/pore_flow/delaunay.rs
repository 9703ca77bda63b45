//! 3-D Delaunay tetrahedralisation of element centres (Bowyer–Watson, incremental).
//!
//! Orientation and in-sphere tests are Shewchuk's adaptive exact predicates (the `robust`
//! crate), so every decision is exact for the points it is given. Regular packings put many
//! points on one sphere (each cube of a simple-cubic lattice, each octahedron of an FCC one),
//! where the Delaunay tetrahedralisation is not unique; instead of symbolic perturbation the
//! points are moved by a tiny deterministic jitter (1e-9 of the bounding box diagonal, a
//! hash of the point's index) before insertion, which makes such ties vanish while keeping
//! the result a function of the input alone. The tetrahedra connect the original (unjittered)
//! points; those that the jitter made from a co-spherical group are near-flat and are merged
//! into a neighbour by the pore network.

use crate::error::{Error, Result};
use crate::physics::Vec3;
use robust::{insphere, orient3d, Coord3D};
use serde::{Deserialize, Serialize};

/// No neighbour across this face: it lies on the convex hull.
pub const HULL: u32 = u32::MAX;

/// A positively oriented tetrahedron (`orient(v0, v1, v2, v3) > 0` for the jittered points)
/// and its neighbours: `n[k]` shares the face opposite `v[k]`, or is [`HULL`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Tet {
    pub v: [u32; 4],
    pub n: [u32; 4],
}

/// The tetrahedralisation of a point set.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Tetrahedralisation {
    pub tets: Vec<Tet>,
    /// The points as inserted (jittered); the predicates ran on these.
    pub points: Vec<[f64; 3]>,
}

/// Relative size of the symbolic-tie-breaking jitter (of the bounding box diagonal).
pub const JITTER: f64 = 1e-9;

fn coord(p: &[f64; 3]) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// `orient3d` in the sign convention used here: positive when `d` sees `a, b, c`
/// clockwise, i.e. det[a−d, b−d, c−d] > 0 — Shewchuk's convention.
fn orient(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> f64 {
    orient3d(coord(a), coord(b), coord(c), coord(d))
}

/// A deterministic value in [-1, 1) from an index (splitmix64).
fn unit_hash(mut x: u64) -> f64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^= x >> 31;
    (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Interleaves the low 21 bits of three integers (Morton order), for an insertion order in
/// which consecutive points are close, so the walk that locates each one is short.
fn morton(mut x: u64, mut y: u64, mut z: u64) -> u64 {
    fn spread(mut v: u64) -> u64 {
        v &= 0x1F_FFFF;
        v = (v | (v << 32)) & 0x1F_0000_0000_FFFF;
        v = (v | (v << 16)) & 0x1F_0000_FF00_00FF;
        v = (v | (v << 8)) & 0x100F_00F0_0F00_F00F;
        v = (v | (v << 4)) & 0x10C3_0C30_C30C_30C3;
        (v | (v << 2)) & 0x1249_2492_4924_9249
    }
    x = spread(x);
    y = spread(y);
    z = spread(z);
    x | (y << 1) | (z << 2)
}

/// The Delaunay tetrahedralisation of `points` (at least 4, not all coplanar). Vertex ids
/// are indices into `points`.
pub fn tetrahedralise(points: &[Vec3]) -> Result<Tetrahedralisation> {
    let n = points.len();
    if n < 4 {
        return Err(Error::InvalidScene(format!(
            "the pore network needs at least 4 elements to form a tetrahedron; the model has {n}"
        )));
    }
    if points.iter().any(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite())) {
        return Err(Error::InvalidScene("the pore network needs finite element positions".into()));
    }
    let mut lo = points[0];
    let mut hi = points[0];
    for p in points {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let diag = (hi - lo).norm();
    if diag == 0.0 {
        return Err(Error::InvalidScene("the pore network needs elements at distinct positions".into()));
    }
    let amp = JITTER * diag;
    let mut pts: Vec<[f64; 3]> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let k = 3 * i as u64;
            [p.x + amp * unit_hash(k), p.y + amp * unit_hash(k + 1), p.z + amp * unit_hash(k + 2)]
        })
        .collect();

    // Super-tetrahedron far outside; exact predicates keep the far vertices harmless.
    let c = (lo + hi) * 0.5;
    let s = 1.0e4 * diag;
    let supers = [
        [c.x - s, c.y - s, c.z - s],
        [c.x + 3.0 * s, c.y - s, c.z - s],
        [c.x - s, c.y + 3.0 * s, c.z - s],
        [c.x - s, c.y - s, c.z + 3.0 * s],
    ];
    pts.extend_from_slice(&supers);
    let sv = [n as u32, n as u32 + 1, n as u32 + 2, n as u32 + 3];
    let mut first = Tet { v: sv, n: [HULL; 4] };
    if orient(&pts[sv[0] as usize], &pts[sv[1] as usize], &pts[sv[2] as usize], &pts[sv[3] as usize]) < 0.0 {
        first.v.swap(0, 1);
    }
    let mut tets = vec![first];
    let mut alive = vec![true];

    // Insertion order: Morton order of the quantised positions.
    let scale = ((1u64 << 21) - 1) as f64 / (hi - lo).max().max(f64::MIN_POSITIVE);
    let mut order: Vec<u32> = (0..n as u32).collect();
    let key = |i: u32| {
        let p = points[i as usize] - lo;
        morton((p.x * scale) as u64, (p.y * scale) as u64, (p.z * scale) as u64)
    };
    order.sort_by_key(|&i| (key(i), i));

    let mut last = 0u32;
    let mut cavity: Vec<u32> = Vec::new();
    let mut in_cavity: Vec<bool> = vec![false];
    let mut stack: Vec<u32> = Vec::new();
    let mut boundary: Vec<(u32, usize)> = Vec::new();
    let mut edges: Vec<([u32; 2], u32, usize)> = Vec::new();
    for (step, &pi) in order.iter().enumerate() {
        let p = pts[pi as usize];
        let start = locate(&tets, &alive, &pts, last, &p, step)?;
        // The cavity: every tetrahedron whose circumsphere holds p, connected to the start.
        cavity.clear();
        stack.clear();
        stack.push(start);
        in_cavity[start as usize] = true;
        while let Some(t) = stack.pop() {
            cavity.push(t);
            for k in 0..4 {
                let nb = tets[t as usize].n[k];
                if nb == HULL || in_cavity[nb as usize] {
                    continue;
                }
                let v = tets[nb as usize].v.map(|i| pts[i as usize]);
                if insphere(coord(&v[0]), coord(&v[1]), coord(&v[2]), coord(&v[3]), coord(&p)) > 0.0 {
                    in_cavity[nb as usize] = true;
                    stack.push(nb);
                }
            }
        }
        // Its boundary faces, each joined to p.
        boundary.clear();
        for &t in &cavity {
            for k in 0..4 {
                let nb = tets[t as usize].n[k];
                if nb == HULL || !in_cavity[nb as usize] {
                    boundary.push((t, k));
                }
            }
        }
        edges.clear();
        let first_new = tets.len() as u32;
        for &(t, k) in &boundary {
            let old = tets[t as usize];
            let mut v = old.v;
            v[k] = pi;
            let id = tets.len() as u32;
            let outside = old.n[k];
            let mut nt = Tet { v, n: [HULL; 4] };
            nt.n[k] = outside;
            if outside != HULL {
                let o = &mut tets[outside as usize];
                let slot = o.n.iter().position(|&x| x == t).expect("neighbour links are mutual");
                o.n[slot] = id;
            }
            // The faces through p: opposite v[j] for j ≠ k, keyed by their other two vertices.
            for j in 0..4 {
                if j == k {
                    continue;
                }
                let mut e = [0u32; 2];
                let mut m = 0;
                for (q, &vq) in v.iter().enumerate() {
                    if q != j && q != k {
                        e[m] = vq;
                        m += 1;
                    }
                }
                e.sort_unstable();
                if let Some(pos) = edges.iter().position(|(ee, _, _)| *ee == e) {
                    let (_, other, oslot) = edges.swap_remove(pos);
                    nt.n[j] = other;
                    tets[other as usize].n[oslot] = id;
                } else {
                    edges.push((e, id, j));
                }
            }
            tets.push(nt);
            alive.push(true);
            in_cavity.push(false);
        }
        if !edges.is_empty() {
            return Err(Error::InvalidScene(
                "the pore network's tetrahedralisation failed (a cavity that is not star-shaped); \
                 check for elements at nearly the same position"
                    .into(),
            ));
        }
        for &t in &cavity {
            alive[t as usize] = false;
            in_cavity[t as usize] = false;
        }
        last = first_new;
    }

    // Keep the tetrahedra of real points; renumber and relink.
    let mut new_id = vec![HULL; tets.len()];
    let mut kept = Vec::new();
    for (i, t) in tets.iter().enumerate() {
        if alive[i] && t.v.iter().all(|&v| (v as usize) < n) {
            new_id[i] = kept.len() as u32;
            kept.push(*t);
        }
    }
    for t in &mut kept {
        for k in 0..4 {
            if t.n[k] != HULL {
                t.n[k] = new_id[t.n[k] as usize];
            }
        }
    }
    pts.truncate(n);
    Ok(Tetrahedralisation { tets: kept, points: pts })
}

/// The live tetrahedron that contains `p`, by a visibility walk from `start`. The face to
/// leave by is tried in an order that turns with `salt`, which keeps the walk from cycling.
fn locate(tets: &[Tet], alive: &[bool], pts: &[[f64; 3]], start: u32, p: &[f64; 3], salt: usize) -> Result<u32> {
    let mut t = start;
    debug_assert!(alive[t as usize]);
    let limit = 4 * tets.len() + 64;
    'walk: for _ in 0..limit {
        let tet = &tets[t as usize];
        let v = tet.v.map(|i| pts[i as usize]);
        for r in 0..4 {
            let k = (r + salt) % 4;
            let mut w = v;
            w[k] = *p;
            if orient(&w[0], &w[1], &w[2], &w[3]) < 0.0 && tet.n[k] != HULL {
                t = tet.n[k];
                continue 'walk;
            }
        }
        return Ok(t);
    }
    Err(Error::InvalidScene("the pore network's tetrahedralisation could not locate a point (walk did not end)".into()))
}

impl Tetrahedralisation {
    /// Signed volume of tetrahedron `t` over the given (unjittered) positions.
    pub fn volume(&self, t: usize, pos: &[Vec3]) -> f64 {
        let [a, b, c, d] = self.tets[t].v.map(|i| pos[i as usize]);
        // Shewchuk's positive orientation is det[a−d, b−d, c−d] > 0.
        (a - d).dot(&(b - d).cross(&(c - d))) / 6.0
    }

    /// Keeps the tetrahedra `keep` marks, their faces towards the others becoming hull faces.
    pub fn retain(&mut self, keep: &[bool]) {
        let mut new_id = vec![HULL; self.tets.len()];
        let mut next = 0u32;
        for (t, &k) in keep.iter().enumerate() {
            if k {
                new_id[t] = next;
                next += 1;
            }
        }
        let mut tets = Vec::with_capacity(next as usize);
        for (t, tet) in self.tets.iter().enumerate() {
            if keep[t] {
                tets.push(Tet { v: tet.v, n: tet.n.map(|n| if n == HULL { HULL } else { new_id[n as usize] }) });
            }
        }
        self.tets = tets;
    }
}
