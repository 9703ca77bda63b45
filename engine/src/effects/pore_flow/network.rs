//! The pore network of a packing: pores are the Delaunay tetrahedra of element centres
//! inside the packing (the wide flat ones between the convex hull and the outer grains are
//! open space), a pore with little room merged into its widest-open neighbour until none has
//! a vanishing volume; throats are the faces between two pores. Topology is
//! built once per rebuild; the geometry (pore volumes and centres, throat conductances)
//! follows the elements every step.

use super::boundary::{BoundaryKind, PoreRegion};
use super::delaunay::{tetrahedralise, Tetrahedralisation, HULL};
use super::geometry::{cubic_law, opening, poiseuille_within, pore_volume, sectors_volume, tet_volume};
use super::Fluid;
use crate::error::Result;
use crate::materials::base_name;
use crate::model::Model;
use crate::physics::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A tetrahedron reached from the hull with an edge whose gap between its two spheres is
/// wider than this many times its corners' mean diameter is open space beyond the packing,
/// not a pore: no grain lies between the two across a gap another grain would fit through.
pub const OUTSIDE_GAP: f64 = 2.0;

/// A pore whose room is under this fraction of a tetrahedron's mean is merged into a
/// neighbour: slivers from co-spherical points and tightly filled corners would otherwise
/// give pores with almost no room, a vanishing stable flow step and a stiff fluid.
pub const SMALL_PORE_FRACTION: f64 = 0.05;

/// A pore's fluid volume is kept above this fraction of its tetrahedra's volume (where
/// overlapping spheres would subtract the same room twice).
pub const VOLUME_FLOOR: f64 = 0.01;

/// A face between two pores: the face of tetrahedron `tet` opposite its corner `face`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Throat {
    pub a: u32,
    pub b: u32,
    pub tet: u32,
    pub face: u8,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct PoreNetwork {
    pub tri: Tetrahedralisation,
    /// Pore of each tetrahedron.
    pub tet_pore: Vec<u32>,
    /// Tetrahedra of pore `p`: `pore_tets[pore_tet_start[p]..pore_tet_start[p + 1]]`.
    pub pore_tet_start: Vec<u32>,
    pub pore_tets: Vec<u32>,
    pub throats: Vec<Throat>,
    /// Throats of pore `p` (CSR rows, each throat in both of its pores' rows), so each pore
    /// sums its own row.
    pub row_start: Vec<u32>,
    pub row: Vec<u32>,
    /// Edges of each throat's face bonded when the network was built (bit e: the edge
    /// opposite the face's e-th corner).
    pub bonded_at_build: Vec<u8>,
    /// Positions when the network was built.
    pub built_at: Vec<Vec3>,
    /// Each element's corners of tetrahedra, for the per-element gather of the pressure
    /// forces: `elem_corners[elem_start[i]..elem_start[i + 1]]`, each `4·tet + corner`, in
    /// tetrahedron order.
    pub elem_start: Vec<u32>,
    pub elem_corners: Vec<u32>,
    /// Orientation of each tetrahedron in the points it was built on (±1): a tetrahedron
    /// flattened or inverted by the motion keeps its side, so shared faces still cancel.
    pub orient: Vec<f64>,
    // Geometry of the current positions (see `refresh`).
    /// Fluid volume of each pore (m³).
    pub volume: Vec<f64>,
    /// Volume-weighted centroid of each pore's tetrahedra (m).
    pub centre: Vec<Vec3>,
    /// Conductance of each throat (m³/(Pa·s)).
    pub conductance: Vec<f64>,
    /// Throat opening (m²).
    pub opening: Vec<f64>,
    /// Whether a bond across the throat's face has broken since the build.
    pub cracked: Vec<bool>,
}

/// The three corners of face `k` of a tetrahedron with corners `v`, in a fixed order.
pub fn face_corners(v: [u32; 4], k: usize) -> [u32; 3] {
    let mut f = [0u32; 3];
    let mut m = 0;
    for (q, &vq) in v.iter().enumerate() {
        if q != k {
            f[m] = vq;
            m += 1;
        }
    }
    f
}

/// The tetrahedra between the convex hull and the packing's outer grains: those reached from
/// the hull through tetrahedra with an edge wider than [`OUTSIDE_GAP`]. The hull bridges the
/// dips of a packing's surface with wide flat tetrahedra (a facet 0.4 m across over grains of
/// 15 mm); as pores, their small volume under a wide face made the fluid a spring 400 times
/// stiffer than the contacts.
///
/// A tetrahedron whose centroid lies in a borehole region (`claimed`) is never open space: a
/// hole drilled through a slab opens to its faces, yet holds the well's fluid, which must push
/// the hole's wall into the rock. Left outside, the hole's wall would be the network's hull,
/// where a pressurised pore's fluid pushes the wall grains into the hole instead.
fn outside_the_packing(
    tri: &Tetrahedralisation,
    pos: &[Vec3],
    rad: &[f64],
    claimed: impl Fn(&Vec3) -> bool,
) -> Vec<bool> {
    let wide = |t: usize| {
        let v = tri.tets[t].v.map(|i| i as usize);
        let diameter = v.iter().map(|&i| 2.0 * rad[i]).sum::<f64>() / 4.0;
        (0..4).any(|a| {
            (a + 1..4).any(|b| (pos[v[a]] - pos[v[b]]).norm() - rad[v[a]] - rad[v[b]] > OUTSIDE_GAP * diameter)
        })
    };
    let mut outside = vec![false; tri.tets.len()];
    let mut stack: Vec<usize> = (0..tri.tets.len()).filter(|&t| tri.tets[t].n.contains(&HULL)).collect();
    while let Some(t) = stack.pop() {
        if outside[t] || !wide(t) || claimed(&(tri.tets[t].v.iter().map(|&i| pos[i as usize]).sum::<Vec3>() / 4.0)) {
            continue;
        }
        outside[t] = true;
        stack.extend(tri.tets[t].n.iter().filter(|&&n| n != HULL).map(|&n| n as usize));
    }
    outside
}

fn bonded(m: &Model, i: u32, j: u32) -> bool {
    m.contacts.find(i as usize, j).is_some_and(|e| m.contacts.state[e].bonded)
}

impl PoreNetwork {
    /// Each element's mean of a per-pore value over the tetrahedra it is a corner of, each
    /// weighted by its volume (its pore's share there); `none` for an element at no corner
    /// (fewer than four elements, or a duplicate position).
    pub fn element_mean(&self, pos: &[Vec3], per_pore: &[f64], none: f64) -> Vec<f64> {
        (0..self.elem_start.len().saturating_sub(1))
            .map(|i| {
                let (mut sum, mut w) = (0.0, 0.0);
                for &e in &self.elem_corners[self.elem_start[i] as usize..self.elem_start[i + 1] as usize] {
                    let t = (e / 4) as usize;
                    let v = tet_volume(self.tri.tets[t].v.map(|j| pos[j as usize])).abs();
                    sum += v * per_pore[self.tet_pore[t] as usize];
                    w += v;
                }
                if w > 0.0 {
                    sum / w
                } else {
                    none
                }
            })
            .collect()
    }

    /// Whether every index in the network lies in range for `n` elements and the network is
    /// as [`PoreNetwork::build`] makes it (a checkpoint is checked before it is stepped: a
    /// well-formed but inconsistent one would otherwise index out of bounds). The error names
    /// the first thing that is wrong.
    pub fn consistent(&self, n: usize) -> Result<(), String> {
        use crate::state::check_row_starts;
        let tets = self.tri.tets.len();
        let pores = self.pore_count();
        let throats = self.throats.len();
        let fail = |what: String| Err(format!("pore network: {what}"));
        if self.tri.points.len() != n || self.built_at.len() != n {
            let (p, b) = (self.tri.points.len(), self.built_at.len());
            return fail(format!("{p} points and {b} build positions for {n} elements"));
        }
        for (t, tet) in self.tri.tets.iter().enumerate() {
            if let Some(&v) = tet.v.iter().find(|&&v| v as usize >= n) {
                return fail(format!("tetrahedron {t} has corner {v}, and the model has {n} elements"));
            }
            if let Some(&nb) = tet.n.iter().find(|&&nb| nb != HULL && nb as usize >= tets) {
                return fail(format!("tetrahedron {t} has neighbour {nb} of {tets} tetrahedra"));
            }
        }
        if self.orient.len() != tets || self.tet_pore.len() != tets {
            let (o, p) = (self.orient.len(), self.tet_pore.len());
            return fail(format!("{o} orientations and {p} pore ids for {tets} tetrahedra"));
        }
        if let Some((t, &p)) = self.tet_pore.iter().enumerate().find(|(_, &p)| p as usize >= pores) {
            return fail(format!("tetrahedron {t} belongs to pore {p} of {pores}"));
        }
        if self.centre.len() != pores {
            return fail(format!("{} pore centres for {pores} pores", self.centre.len()));
        }
        check_row_starts("pore network tetrahedra", &self.pore_tet_start, pores, self.pore_tets.len())?;
        if self.pore_tets.len() != tets {
            return fail(format!("its pores list {} tetrahedra of {tets}", self.pore_tets.len()));
        }
        for p in 0..pores {
            // Every pore has a tetrahedron (its centre falls back on the first one's corners).
            if self.tets_of(p).is_empty() {
                return fail(format!("pore {p} has no tetrahedra"));
            }
            if let Some(&t) =
                self.tets_of(p).iter().find(|&&t| t as usize >= tets || self.tet_pore[t as usize] as usize != p)
            {
                return fail(format!("pore {p} lists tetrahedron {t} (of {tets}), which is not its own"));
            }
        }
        for (k, th) in self.throats.iter().enumerate() {
            if !(th.a < th.b && (th.b as usize) < pores && (th.tet as usize) < tets && th.face < 4) {
                let Throat { a, b, tet, face } = th;
                return fail(format!(
                    "throat {k} joins pores {a} and {b} of {pores} at face {face} of tetrahedron {tet}"
                ));
            }
        }
        let lanes = [self.bonded_at_build.len(), self.conductance.len(), self.opening.len(), self.cracked.len()];
        if lanes.iter().any(|&l| l != throats) {
            return fail(format!("throat lanes of {lanes:?} entries for {throats} throats"));
        }
        check_row_starts("pore network throats", &self.row_start, pores, self.row.len())?;
        for p in 0..pores {
            let touches =
                |t: u32| self.throats.get(t as usize).is_some_and(|th| th.a as usize == p || th.b as usize == p);
            if let Some(&t) = self.throats_of(p).iter().find(|&&t| !touches(t)) {
                return fail(format!("pore {p} lists throat {t}, which does not join it"));
            }
        }
        check_row_starts("pore network corners", &self.elem_start, n, self.elem_corners.len())?;
        for i in 0..n {
            let corners = &self.elem_corners[self.elem_start[i] as usize..self.elem_start[i + 1] as usize];
            let at = |c: u32| self.tri.tets.get(c as usize / 4).is_some_and(|t| t.v[c as usize % 4] as usize == i);
            if let Some(&c) = corners.iter().find(|&&c| !at(c)) {
                return fail(format!("element {i} lists tetrahedron corner {c}, which is not its own"));
            }
        }
        Ok(())
    }

    /// The network of the model's current packing.
    pub fn build(m: &Model) -> Result<Self> {
        let pos = &m.particles.pos;
        let rad = &m.particles.radius;
        let mut tri = tetrahedralise(pos)?;
        // The open space of a borehole region whose fluid is held or injected is the well's.
        let bores: Vec<&PoreRegion> = m
            .settings
            .pores
            .boundaries
            .iter()
            .filter(|b| b.kind != BoundaryKind::Impermeable && matches!(b.region, PoreRegion::Cylinder { .. }))
            .map(|b| &b.region)
            .collect();
        let outside = outside_the_packing(&tri, pos, rad, |c| bores.iter().any(|r| r.contains(c) == Some(true)));
        if outside.iter().any(|&o| o) && !outside.iter().all(|&o| o) {
            tri.retain(&outside.iter().map(|&o| !o).collect::<Vec<_>>());
        }
        let nt = tri.tets.len();
        let corners = |t: usize| tri.tets[t].v.map(|i| pos[i as usize]);
        let radii = |t: usize| tri.tets[t].v.map(|i| rad[i as usize]);
        let empty: Vec<f64> = (0..nt).map(|t| pore_volume(corners(t), radii(t), 0.0)).collect();
        let mean = empty.iter().sum::<f64>() / nt.max(1) as f64;
        let mut parent: Vec<u32> = (0..nt as u32).collect();
        fn root(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                parent[x as usize] = parent[parent[x as usize] as usize];
                x = parent[x as usize];
            }
            x
        }
        fn join(parent: &mut [u32], a: u32, b: u32) -> bool {
            let (a, b) = (root(parent, a), root(parent, b));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
            a != b
        }
        // Merge small pores into the neighbour across their widest-open face, as often as it
        // takes: a pore's room is that of its tetrahedra together, as `refresh` counts it.
        let room: Vec<f64> =
            (0..nt).map(|t| tet_volume(corners(t)).abs() - sectors_volume(corners(t), radii(t))).collect();
        for _ in 0..nt {
            let mut pore_room = vec![0.0; nt];
            for t in 0..nt {
                pore_room[root(&mut parent, t as u32) as usize] += room[t];
            }
            // The widest-open face from each small pore to another pore: (area, face area, neighbour).
            let mut best: Vec<Option<(f64, f64, u32)>> = vec![None; nt];
            for t in 0..nt {
                let a = root(&mut parent, t as u32);
                if pore_room[a as usize] >= SMALL_PORE_FRACTION * mean {
                    continue;
                }
                let tet = tri.tets[t];
                for k in 0..4 {
                    if tet.n[k] == HULL || root(&mut parent, tet.n[k]) == a {
                        continue;
                    }
                    let f = face_corners(tet.v, k);
                    let o = opening(f.map(|i| pos[i as usize]), f.map(|i| rad[i as usize]));
                    let key = (o.area, o.face, tet.n[k]);
                    if best[a as usize].is_none_or(|b| (key.0, key.1) > (b.0, b.1)) {
                        best[a as usize] = Some(key);
                    }
                }
            }
            let mut merged = false;
            for (a, b) in best.iter().enumerate() {
                if let Some((_, _, nb)) = b {
                    merged |= join(&mut parent, a as u32, *nb);
                }
            }
            if !merged {
                break;
            }
        }
        let mut id = vec![u32::MAX; nt];
        let mut tet_pore = vec![0u32; nt];
        let mut pores = 0u32;
        for t in 0..nt {
            let r = root(&mut parent, t as u32) as usize;
            if id[r] == u32::MAX {
                id[r] = pores;
                pores += 1;
            }
            tet_pore[t] = id[r];
        }
        let np = pores as usize;
        let (pore_tet_start, pore_tets) = csr(np, (0..nt as u32).map(|t| (tet_pore[t as usize], t)));

        let mut throats = Vec::new();
        let mut bonded_at_build = Vec::new();
        for (t, tet) in tri.tets.iter().enumerate() {
            for k in 0..4 {
                let nb = tet.n[k];
                if nb == HULL || (nb as usize) < t {
                    continue;
                }
                let (a, b) = (tet_pore[t], tet_pore[nb as usize]);
                if a == b {
                    continue;
                }
                throats.push(Throat { a: a.min(b), b: a.max(b), tet: t as u32, face: k as u8 });
                let f = face_corners(tet.v, k);
                let mut bits = 0u8;
                for e in 0..3 {
                    if bonded(m, f[(e + 1) % 3], f[(e + 2) % 3]) {
                        bits |= 1 << e;
                    }
                }
                bonded_at_build.push(bits);
            }
        }
        let (row_start, row) =
            csr(np, throats.iter().enumerate().flat_map(|(i, th)| [(th.a, i as u32), (th.b, i as u32)]));
        let nth = throats.len();
        let (elem_start, elem_corners) = csr(
            pos.len(),
            tri.tets.iter().enumerate().flat_map(|(t, tet)| (0..4).map(move |c| (tet.v[c], 4 * t as u32 + c as u32))),
        );
        let orient = tri
            .tets
            .iter()
            .map(|tet| if tet_volume(tet.v.map(|i| Vec3::from(tri.points[i as usize]))) < 0.0 { -1.0 } else { 1.0 })
            .collect();
        let mut net = PoreNetwork {
            tri,
            tet_pore,
            pore_tet_start,
            pore_tets,
            throats,
            row_start,
            row,
            bonded_at_build,
            built_at: pos.clone(),
            elem_start,
            elem_corners,
            orient,
            volume: vec![0.0; np],
            centre: vec![Vec3::zeros(); np],
            conductance: vec![0.0; nth],
            opening: vec![0.0; nth],
            cracked: vec![false; nth],
        };
        net.refresh(m, &Fluid::default());
        Ok(net)
    }

    pub fn pore_count(&self) -> usize {
        self.volume.len()
    }

    /// Tetrahedra of pore `p`.
    pub fn tets_of(&self, p: usize) -> &[u32] {
        &self.pore_tets[self.pore_tet_start[p] as usize..self.pore_tet_start[p + 1] as usize]
    }

    /// Throats of pore `p`.
    pub fn throats_of(&self, p: usize) -> &[u32] {
        &self.row[self.row_start[p] as usize..self.row_start[p + 1] as usize]
    }

    /// Recomputes volumes, centres and conductances from the current positions and bonds.
    pub fn refresh(&mut self, m: &Model, fluid: &Fluid) {
        let pos = &m.particles.pos;
        let rad = &m.particles.radius;
        let tri = &self.tri;
        let tets = |p: usize| &self.pore_tets[self.pore_tet_start[p] as usize..self.pore_tet_start[p + 1] as usize];
        let geo: Vec<(f64, Vec3)> = (0..self.volume.len())
            .into_par_iter()
            .map(|p| {
                let (mut empty, mut full, mut c) = (0.0, 0.0, Vec3::zeros());
                for &t in tets(p) {
                    let v = tri.tets[t as usize].v;
                    let x = v.map(|i| pos[i as usize]);
                    let vol = tet_volume(x).abs();
                    // Signed, not clamped per tetrahedron: a merged pore's tetrahedra add up to
                    // the room between the spheres exactly, and every change of a tetrahedron's
                    // volume (the grains' motion) changes the pore's by as much.
                    empty += vol - sectors_volume(x, v.map(|i| rad[i as usize]));
                    full += vol;
                    c += (x[0] + x[1] + x[2] + x[3]) * (0.25 * vol);
                }
                let centre = if full > 0.0 {
                    c / full
                } else {
                    let v = tri.tets[tets(p)[0] as usize].v;
                    v.iter().map(|&i| pos[i as usize]).sum::<Vec3>() / 4.0
                };
                (empty.max(VOLUME_FLOOR * full), centre)
            })
            .collect();
        for (p, (v, c)) in geo.into_iter().enumerate() {
            self.volume[p] = v;
            self.centre[p] = c;
        }
        let centre = &self.centre;
        let volume = &self.volume;
        let factors = material_factors(m, fluid);
        let material = &m.particles.material;
        let out: Vec<(f64, f64, bool)> = self
            .throats
            .par_iter()
            .zip(self.bonded_at_build.par_iter())
            .map(|(th, &bits)| {
                let f = face_corners(tri.tets[th.tet as usize].v, th.face as usize);
                let x = f.map(|i| pos[i as usize]);
                let r = f.map(|i| rad[i as usize]);
                let o = opening(x, r);
                let mean_r = (r[0] + r[1] + r[2]) / 3.0;
                let len = (centre[th.a as usize] - centre[th.b as usize]).norm().max(0.1 * mean_r);
                let mut cracked = false;
                let mut crack_g = 0.0;
                for e in 0..3 {
                    if bits & (1 << e) == 0 {
                        continue;
                    }
                    let (i, j) = (f[(e + 1) % 3], f[(e + 2) % 3]);
                    if !bonded(m, i, j) {
                        cracked = true;
                        let (xi, xj) = (pos[i as usize], pos[j as usize]);
                        let (ri, rj) = (rad[i as usize], rad[j as usize]);
                        let gap = (xi - xj).norm() - ri - rj;
                        let w = gap.max(fluid.crack_aperture * mean_r);
                        crack_g += cubic_law(w, ri.min(rj), fluid.viscosity, len);
                    }
                }
                let cemented = bits != 0 && !cracked;
                let mut factor = if cemented { fluid.cement_factor } else { 1.0 };
                if let Some(k) = &factors {
                    factor *= face_factor(k, material, f);
                }
                // The pores' thickness across the face, the height 3V/A of a tetrahedron of
                // the smaller pore's fluid volume on it: a sliver's (the convex hull's flat
                // tetrahedra) is tiny, and so is the passage through it.
                let thickness = 3.0 * volume[th.a as usize].min(volume[th.b as usize]) / o.face.max(f64::MIN_POSITIVE);
                (poiseuille_within(&o, thickness, fluid.viscosity, len) * factor + crack_g, o.area, cracked)
            })
            .collect();
        for (t, (g, a, c)) in out.into_iter().enumerate() {
            self.conductance[t] = g;
            self.opening[t] = a;
            self.cracked[t] = c;
        }
    }

    /// Each throat's permeability factor: the harmonic mean of its face's corners' material
    /// factors (1 each when the fluid names none), as [`Self::refresh`] applies it.
    pub fn throat_factors(&self, m: &Model, fluid: &Fluid) -> Vec<f64> {
        let Some(k) = material_factors(m, fluid) else { return vec![1.0; self.throats.len()] };
        self.throats
            .iter()
            .map(|th| {
                face_factor(&k, &m.particles.material, face_corners(self.tri.tets[th.tet as usize].v, th.face as usize))
            })
            .collect()
    }

    /// The largest distance any element has moved since the network was built (m).
    pub fn drift(&self, m: &Model) -> f64 {
        m.particles.pos.iter().zip(&self.built_at).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max)
    }

    /// The pore whose tetrahedra contain `x`, if any (a walk over all tetrahedra; for
    /// carrying fluid over a rebuild, not for the step loop).
    pub fn pore_at(&self, pos: &[Vec3], x: Vec3) -> Option<usize> {
        self.tri
            .tets
            .iter()
            .position(|t| {
                let v = t.v.map(|i| pos[i as usize]);
                (0..4).all(|k| {
                    let mut w = v;
                    w[k] = x;
                    tet_volume(w) * tet_volume(v) >= 0.0
                })
            })
            .map(|t| self.tet_pore[t] as usize)
    }
}

/// Per-material permeability factors (`None` when the fluid names none): each material's, or
/// a per-element clone's (`rock~3`) base material's, 1 for a material not named.
fn material_factors(m: &Model, fluid: &Fluid) -> Option<Vec<f64>> {
    (!fluid.permeability.is_empty()).then(|| {
        let named = |n: &str| fluid.permeability.get(n).copied();
        m.materials.iter().map(|mat| named(&mat.name).or_else(|| named(base_name(&mat.name))).unwrap_or(1.0)).collect()
    })
}

/// The harmonic mean of a face's corners' factors: a passage is as tight as its tightest walls
/// make it, in series.
fn face_factor(k: &[f64], material: &[u32], f: [u32; 3]) -> f64 {
    let inv: f64 = f.iter().map(|&i| 1.0 / k[material[i as usize] as usize]).sum();
    3.0 / inv
}

/// CSR rows from (row, value) pairs, values in each row in the order given.
fn csr(rows: usize, items: impl Iterator<Item = (u32, u32)> + Clone) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; rows + 1];
    for (r, _) in items.clone() {
        start[r as usize + 1] += 1;
    }
    for r in 0..rows {
        start[r + 1] += start[r];
    }
    let mut fill = start.clone();
    let mut out = vec![0u32; start[rows] as usize];
    for (r, v) in items {
        out[fill[r as usize] as usize] = v;
        fill[r as usize] += 1;
    }
    (start, out)
}
