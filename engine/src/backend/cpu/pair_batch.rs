//! The pair pass four pairs at a time: the common case, an unbonded pair in contact, goes
//! through the law in four f64 lanes (lanes.rs); a pair that is bonded, apart or just opened
//! goes through the scalar law (`one_pair`), in its lane's turn.
//!
//! The lanes compute what `contact` computes for a touching unbonded pair, operation for
//! operation, with each branch taken as a per-lane choice between both sides; so every
//! record comes out bit for bit as the scalar law writes it (the test
//! `the_pair_pass_four_at_a_time_matches_the_scalar_law_bit_for_bit` holds it to that on
//! every law, sliding, opening and bonded pairs included). The laws' own formulas (normal
//! force, stiffnesses, dashpots) are called lane by lane, so they are written once.

use super::lanes::{LANES, M4, V4, X4};
use super::pair_records::{one_pair, BlockPairs, Breaks, PairInputs, PairOut};
use crate::physics::contact_law::{NormalLaw, PairParams, PairState, TangentialLaw};
use crate::physics::Vec3;

/// Whether this processor runs the AVX2 build of the pass (checked once a pass).
pub(super) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Runs one block of the pair pass; returns its broken bonds in pair order.
pub(super) fn run<
    N: NormalLaw,
    T: TangentialLaw,
    const DASHPOT: bool,
    const ROT: bool,
    const PERIODIC: bool,
    const PLANAR: bool,
>(
    inp: &PairInputs,
    block: BlockPairs,
    avx2: bool,
) -> Breaks {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` comes from `has_avx2`, so this processor has the instructions the
        // function is compiled for.
        return unsafe { run_avx2::<N, T, DASHPOT, ROT, PERIODIC, PLANAR>(inp, block) };
    }
    let _ = avx2;
    run_block::<N, T, DASHPOT, ROT, PERIODIC, PLANAR>(inp, block)
}

/// [`run_block`] compiled for AVX2 (four lanes in one instruction; no FMA, so the roundings
/// are the scalar law's).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_avx2<
    N: NormalLaw,
    T: TangentialLaw,
    const DASHPOT: bool,
    const ROT: bool,
    const PERIODIC: bool,
    const PLANAR: bool,
>(
    inp: &PairInputs,
    block: BlockPairs,
) -> Breaks {
    run_block::<N, T, DASHPOT, ROT, PERIODIC, PLANAR>(inp, block)
}

/// Up to four pairs waiting for the law.
#[derive(Default)]
struct Batch {
    len: usize,
    /// Lower and higher id.
    i: [usize; LANES],
    j: [usize; LANES],
    /// Block-local record.
    k: [usize; LANES],
    /// The pair's entry in the lower id's row.
    e: [usize; LANES],
}

/// The block's pairs in row order, queued in fours; a last batch of fewer goes scalar.
#[inline(always)]
fn run_block<
    N: NormalLaw,
    T: TangentialLaw,
    const DASHPOT: bool,
    const ROT: bool,
    const PERIODIC: bool,
    const PLANAR: bool,
>(
    inp: &PairInputs,
    mut block: BlockPairs,
) -> Breaks {
    let rows = block.rows;
    let base = rows.pair_start[block.range.start] as usize;
    let mut breaks = Breaks::default();
    let mut batch = Batch::default();
    for i in block.range.clone() {
        // The pairs this particle owns end its row.
        let (first_pair, end) = (rows.pair_start[i] as usize, rows.row_start[i + 1] as usize);
        let first = end - (rows.pair_start[i + 1] as usize - first_pair);
        for (n, &j) in rows.other[first..end].iter().enumerate() {
            debug_assert!(j as usize > i && rows.pair[first + n] as usize == first_pair + n);
            let l = batch.len;
            (batch.i[l], batch.j[l], batch.k[l], batch.e[l]) = (i, j as usize, first_pair - base + n, first + n);
            batch.len += 1;
            if batch.len == LANES {
                four_pairs::<N, T, DASHPOT, ROT, PERIODIC, PLANAR>(inp, &batch, &mut block, &mut breaks);
                batch.len = 0;
            }
        }
    }
    for l in 0..batch.len {
        scalar_pair::<N, T, DASHPOT, PERIODIC>(inp, &batch, l, &mut block, &mut breaks);
    }
    breaks
}

/// Lane `l`'s pair through the scalar law.
#[inline(always)]
fn scalar_pair<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const PERIODIC: bool>(
    inp: &PairInputs,
    b: &Batch,
    l: usize,
    block: &mut BlockPairs,
    breaks: &mut Breaks,
) {
    let st = block.state(b.k[l], b.e[l]);
    let (record, td, broke) = one_pair::<N, T, DASHPOT, PERIODIC>(inp, b.i[l], b.j[l], st);
    block.store::<T>(b.k[l], record, td);
    if let Some(kind) = broke {
        breaks.0.push((b.i[l] as u32, b.j[l] as u32, kind));
    }
}

/// Four pairs: the lanes that are unbonded and in contact through the lane law, the others
/// one by one through the scalar law, in lane order (so breaks stay in pair order).
#[inline(always)]
fn four_pairs<
    N: NormalLaw,
    T: TangentialLaw,
    const DASHPOT: bool,
    const ROT: bool,
    const PERIODIC: bool,
    const PLANAR: bool,
>(
    inp: &PairInputs,
    b: &Batch,
    block: &mut BlockPairs,
    breaks: &mut Breaks,
) {
    let st: [PairState; LANES] = std::array::from_fn(|l| block.state(b.k[l], b.e[l]));
    let (ri, rj) = (X4::lanes(|l| inp.radius[b.i[l]]), X4::lanes(|l| inp.radius[b.j[l]]));
    let (d, slide) = if PERIODIC {
        let s: [(Vec3, f64); LANES] = std::array::from_fn(|l| inp.separation::<true>(b.i[l], b.j[l]));
        (V4::<PLANAR>::lanes(|l| s[l].0), X4::lanes(|l| s[l].1))
    } else {
        (V4::<PLANAR>::lanes(|l| inp.pos[b.j[l]]) - V4::lanes(|l| inp.pos[b.i[l]]), X4::lanes(|_| 0.0))
    };
    let touch = ri + rj;
    let dist2 = d.norm_squared();
    let dist = dist2.sqrt();
    let overlap = touch - dist;
    // The scalar law's path for an unbonded pair in contact: not apart by the squared test,
    // and a positive overlap (`contact`'s `touching`). A NaN fails both and goes scalar.
    let fast = M4(std::array::from_fn(|l| !st[l].bonded && dist2.0[l] < touch.0[l] * touch.0[l] && overlap.0[l] > 0.0));
    if fast.any() {
        let params: [&PairParams; LANES] =
            std::array::from_fn(|l| inp.plan.pair(inp.material[b.i[l]], inp.material[b.j[l]]));
        let nrm = d / dist;
        let mut v_rel = V4::<PLANAR>::lanes(|l| inp.vel[b.i[l]]) - V4::lanes(|l| inp.vel[b.j[l]]);
        if PERIODIC {
            v_rel.x = v_rel.x + slide;
        }
        if let (true, Some(w)) = (ROT, inp.ang_vel) {
            let (wi, wj) = (V4::lanes(|l| w[b.i[l]]), V4::lanes(|l| w[b.j[l]]));
            v_rel = v_rel + ((nrm * ri).spun_by(&wi) - (nrm * -rj).spun_by(&wj));
        }
        let (mi, mj) = (X4::lanes(|l| inp.mass[b.i[l]]), X4::lanes(|l| inp.mass[b.j[l]]));
        let lane = LanePair { n: nrm, overlap, v_rel, r_star: ri * rj / touch, m_star: mi * mj / (mi + mj) };
        let out = lane_contact::<N, T, DASHPOT, PLANAR>(&lane, &params, &st, inp.dt);
        for l in 0..LANES {
            if fast.0[l] {
                let state = PairState { shear: out.shear.get(l), dashpot: out.dashpot[l], ..st[l] };
                let record = PairOut {
                    state,
                    normal: nrm.get(l),
                    normal_force: out.normal_force.0[l],
                    heat: [out.heat_damping.0[l], out.heat_friction.0[l], 0.0],
                };
                block.store::<T>(b.k[l], record, out.tangential_dashpot.get(l));
            }
        }
    }
    for l in 0..LANES {
        if !fast.0[l] {
            scalar_pair::<N, T, DASHPOT, PERIODIC>(inp, b, l, block, breaks);
        }
    }
}

/// `ContactGeometry` in lanes.
struct LanePair<const P: bool> {
    n: V4<P>,
    overlap: X4,
    v_rel: V4<P>,
    r_star: X4,
    m_star: X4,
}

/// What `contact` leaves of an unbonded pair in contact, in lanes.
struct LaneResult<const P: bool> {
    /// The new shear spring force.
    shear: V4<P>,
    /// The new normal dashpot force (the pair state's).
    dashpot: [f32; LANES],
    normal_force: X4,
    tangential_dashpot: V4<P>,
    heat_damping: X4,
    heat_friction: X4,
}

/// `contact` for unbonded pairs with a positive overlap, lane by lane: the same operations in
/// the same order, each `if` a choice between both sides. Lanes outside that case compute
/// numbers nobody reads.
#[inline(always)]
fn lane_contact<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const P: bool>(
    g: &LanePair<P>,
    p: &[&PairParams; LANES],
    st: &[PairState; LANES],
    dt: f64,
) -> LaneResult<P> {
    let dt4 = X4::splat(dt);
    let zero = X4::splat(0.0);
    // Touching: the overlap is its own clamp at zero.
    let compressed = g.overlap;
    let fn_el = X4::lanes(|l| N::force(p[l], g.r_star.0[l], compressed.0[l]));
    let vn = g.v_rel.dot(&g.n);
    let kt = X4::lanes(|l| T::stiffness(p[l], g.r_star.0[l], compressed.0[l]));
    let vt = g.v_rel - g.n * vn;
    let s_prev = rotate_into_plane(V4::<P>::lanes(|l| st[l].shear), &g.n);
    let mut s = s_prev - vt * (kt * dt4);
    let mut fn_total = fn_el;
    let mut heat_damping = zero;
    let mut dashpot = std::array::from_fn(|l| st[l].dashpot);
    if DASHPOT {
        let c = X4::lanes(|l| N::dashpot(p[l], g.r_star.0[l], g.m_star.0[l], compressed.0[l]));
        let f_dash = c * vn;
        fn_total = fn_total + f_dash;
        let last = X4::lanes(|l| f64::from(st[l].dashpot));
        heat_damping = X4::splat(0.5) * (last + f_dash) * vn * dt4;
        dashpot = f_dash.0.map(|f| f as f32);
    }
    let damped = T::DAMPED && DASHPOT;
    let f_td = if damped { vt * -X4::lanes(|l| T::dashpot(p[l], g.m_star.0[l], kt.0[l])) } else { V4::zeros() };
    let heat_td = if damped { -f_td.dot(&vt) * dt4 } else { zero };
    heat_damping = heat_damping + heat_td;
    let total = if T::DAMPED { s + f_td } else { s };
    let limit = X4::lanes(|l| p[l].mu) * fn_el.max(zero);
    let s2 = total.norm_squared();
    let mut f_felt = f_td;
    let mut heat_friction = zero;
    let sliding = s2.gt(limit * limit);
    if sliding.any() {
        let mag = s2.sqrt();
        let (capped, felt) = if T::DAMPED {
            let d2 = f_td.norm_squared();
            let felt = d2.gt(limit * limit).select_v(f_td * (limit / d2.sqrt()), f_td);
            (total * (limit / mag) - felt, felt)
        } else {
            (s * (limit / mag), f_felt)
        };
        let (friction, damping) = if T::DAMPED {
            let slip = released_signed(s, capped, s_prev, kt) - felt.dot(&vt) * dt4;
            (slip.max(zero), heat_damping + (slip.min(zero) - heat_td))
        } else {
            (released_signed(s, capped, s_prev, kt).max(zero), heat_damping)
        };
        heat_friction = sliding.select(friction, zero);
        heat_damping = sliding.select(damping, heat_damping);
        f_felt = sliding.select_v(felt, f_felt);
        s = sliding.select_v(capped, s);
    }
    LaneResult { shear: s, dashpot, normal_force: fn_total, tangential_dashpot: f_felt, heat_damping, heat_friction }
}

/// `contact_law::rotate_into_plane` in lanes.
#[inline(always)]
fn rotate_into_plane<const P: bool>(s: V4<P>, n: &V4<P>) -> V4<P> {
    let zero = X4::splat(0.0);
    let s2 = s.norm_squared();
    let p = s - *n * n.dot(&s);
    let p2 = p.norm_squared();
    let rotated = p2.eq(zero).select_v(V4::zeros(), p * (s2 / p2).sqrt());
    s2.eq(zero).select_v(s, rotated)
}

/// `contact_law::released_signed` in lanes.
#[inline(always)]
fn released_signed<const P: bool>(trial: V4<P>, kept: V4<P>, prev: V4<P>, k: X4) -> X4 {
    let zero = X4::splat(0.0);
    let r = X4::splat(0.5) * (trial - kept).dot(&(kept + prev)) / k;
    k.gt(zero).select(r, zero)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::cpu::pair_records::{PairOut, PairRows};
    use crate::materials::Material;
    use crate::model::{Model, NormalKind, TangentialKind};
    use crate::physics::Vec3;
    use crate::plan::StepPlan;

    fn same(a: Vec3, b: Vec3) -> bool {
        a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// Bit for bit; in the planar lanes, value for value (a skipped y term can leave +0
    /// where the 3D sum leaves −0, and nothing else).
    fn same_in<const PLANAR: bool>(a: Vec3, b: Vec3) -> bool {
        if PLANAR {
            a == b
        } else {
            same(a, b)
        }
    }

    fn same_f<const PLANAR: bool>(a: f64, b: f64) -> bool {
        if PLANAR {
            a == b
        } else {
            a.to_bits() == b.to_bits()
        }
    }

    /// A small xorshift, so the scene is the same on every machine.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn vec(&mut self, scale: f64) -> Vec3 {
            Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * scale
        }
    }

    /// A jittered grid of two materials, pressed and apart pairs in its rows, spinning and
    /// moving elements, and pair states of every kind: fresh, sheared (many beyond their
    /// friction cap), with a last dashpot force, bonded (some weakened, some stretched to
    /// break) and just opened.
    /// With `planar`, one layer of it in the x–z plane of a 2D model (every centre, velocity
    /// and shear spring in the plane, every spin about y).
    fn scene(normal: NormalKind, tangential: TangentialKind, restitution: f64, planar: bool) -> Model {
        let mut m = Model::new();
        m.settings.normal = normal;
        m.settings.tangential = tangential;
        m.settings.rotation = true;
        let r0 = 0.01;
        for (name, kn, mu) in [("a", 2e5, 0.5), ("b", 5e5, 0.3)] {
            let mut mat = Material::from_micro(name, 2600.0, kn, 0.4 * kn, 1e-4, 2.0, mu, r0).unwrap();
            mat.restitution = restitution;
            mat.poisson = 0.2;
            m.add_material(mat).unwrap();
        }
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let (n, layers) = if planar { (25, 1) } else { (7, 7) };
        let flat = |v: Vec3| if planar { Vec3::new(v.x, 0.0, v.z) } else { v };
        for k in 0..n * layers * n {
            let cell = Vec3::new((k % n) as f64, (k / n % layers) as f64, (k / (n * layers)) as f64);
            let pos = flat(cell * 1.95 * r0 + rng.vec(0.2 * r0));
            let radius = r0 * (0.9 + 0.2 * rng.next());
            m.add_particle(pos, radius, (k % 3 == 0) as u32).unwrap();
        }
        m.particles.enable_rotation();
        for i in 0..m.particles.len() {
            m.particles.vel[i] = flat(rng.vec(1.0));
            let w = rng.vec(200.0);
            m.particles.rotation.as_mut().unwrap().ang_vel[i] = if planar { Vec3::new(0.0, w.y, 0.0) } else { w };
        }
        if planar {
            m.make_planar(None).unwrap();
        }
        m.contacts.skin = 0.5 * r0;
        crate::neighbours::rebuild(&mut m);
        for st in m.contacts.state.iter_mut() {
            let kind = rng.next();
            if kind < 0.6 {
                // From far inside the friction cap to far beyond it (1e-3 to 1e3 N).
                let magnitude = 10f64.powf(6.0 * rng.next() - 3.0);
                st.shear = flat(rng.vec(magnitude));
            }
            if rng.next() < 0.5 {
                st.dashpot = (rng.next() - 0.5) as f32;
            }
            if rng.next() < 0.15 {
                st.bonded = true;
                st.weakened = if rng.next() < 0.5 { 30_000 } else { 0 };
            }
        }
        m
    }

    /// Every pair of the scene through the four-lane pass (the portable build and, where the
    /// processor has it, AVX2) and through the scalar law, records compared bit for bit.
    /// Returns how many pairs took the lanes, slid in them, and took the scalar law.
    fn compare<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool>(
        m: &Model,
        plan: &StepPlan,
    ) -> [usize; 3] {
        if m.settings.planar.is_some() {
            compare_in::<N, T, DASHPOT, ROT, true>(m, plan)
        } else {
            compare_in::<N, T, DASHPOT, ROT, false>(m, plan)
        }
    }

    fn compare_in<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool, const ROT: bool, const PLANAR: bool>(
        m: &Model,
        plan: &StepPlan,
    ) -> [usize; 3] {
        let (p, c) = (&m.particles, &m.contacts);
        let inp = PairInputs { dt: 1e-5, ..PairInputs::of(m, plan, ROT) };
        let rows = PairRows::of(c);
        let pairs = c.pair_count();
        let mut expected = vec![(PairOut::default(), Vec3::zeros(), None); pairs];
        for i in 0..p.len() {
            let (first_pair, end) = (c.pair_start[i] as usize, c.row_start[i + 1] as usize);
            let first = end - (c.pair_start[i + 1] as usize - first_pair);
            for (n, &j) in c.other[first..end].iter().enumerate() {
                expected[first_pair + n] = one_pair::<N, T, DASHPOT, false>(&inp, i, j as usize, c.state[first + n]);
            }
        }
        for avx2 in [false, has_avx2()] {
            let mut out = vec![PairOut::default(); pairs];
            let mut dashpots = vec![Vec3::zeros(); pairs];
            let block = BlockPairs {
                range: 0..p.len(),
                rows: &rows,
                from_records: false,
                out: &mut out,
                dashpots: Some(&mut dashpots[..]).filter(|_| T::DAMPED),
            };
            let breaks = run::<N, T, DASHPOT, ROT, false, PLANAR>(&inp, block, avx2);
            let expected_breaks: Vec<_> = (0..p.len())
                .flat_map(|i| {
                    let (first_pair, end) = (c.pair_start[i] as usize, c.row_start[i + 1] as usize);
                    let first = end - (c.pair_start[i + 1] as usize - first_pair);
                    let expected = &expected;
                    c.other[first..end]
                        .iter()
                        .enumerate()
                        .filter_map(move |(n, &j)| expected[first_pair + n].2.map(|kind| (i as u32, j, kind)))
                })
                .collect();
            assert_eq!(breaks.0, expected_breaks, "{} {} avx2 {avx2}: breaks", N::NAME, T::NAME);
            for (k, (record, (want, td, _))) in out.iter().zip(&expected).enumerate() {
                let what = format!(
                    "{} {} dashpot {DASHPOT} rot {ROT} planar {PLANAR} avx2 {avx2}, pair {k}",
                    N::NAME,
                    T::NAME
                );
                assert!(same_in::<PLANAR>(record.state.shear, want.state.shear), "{what}: shear");
                assert!(same_f::<PLANAR>(record.state.dashpot.into(), want.state.dashpot.into()), "{what}: dashpot");
                assert_eq!((record.state.bonded, record.state.weakened), (want.state.bonded, want.state.weakened));
                assert!(same_in::<PLANAR>(record.normal, want.normal), "{what}: normal");
                assert!(same_f::<PLANAR>(record.normal_force, want.normal_force), "{what}: normal force");
                for h in 0..3 {
                    assert!(same_f::<PLANAR>(record.heat[h], want.heat[h]), "{what}: heat {h}");
                }
                if T::DAMPED {
                    assert!(same_in::<PLANAR>(dashpots[k], *td), "{what}: tangential dashpot");
                }
                if PLANAR {
                    // Nothing leaves the plane.
                    assert!(record.state.shear.y == 0.0 && record.normal.y == 0.0, "{what}: out of the plane");
                }
            }
        }
        // Which path each pair took, from the scalar side: unbonded and pressed is the lanes'.
        let mut count = [0; 3];
        for i in 0..p.len() {
            let (first_pair, end) = (c.pair_start[i] as usize, c.row_start[i + 1] as usize);
            let first = end - (c.pair_start[i + 1] as usize - first_pair);
            for (n, &j) in c.other[first..end].iter().enumerate() {
                let touch = p.radius[i] + p.radius[j as usize];
                let pressed = (p.pos[j as usize] - p.pos[i]).norm() < touch;
                if pressed && !c.state[first + n].bonded {
                    count[0] += 1;
                    count[1] += usize::from(expected[first_pair + n].0.heat[1] > 0.0);
                } else {
                    count[2] += 1;
                }
            }
        }
        count
    }

    #[test]
    fn the_pair_pass_four_at_a_time_matches_the_scalar_law_bit_for_bit() {
        every_law_matches_the_scalar_law(false);
    }

    // A 2D model's pairs take the planar lanes (two components): the scalar law's numbers all
    // the same, to the sign of a zero.
    #[test]
    fn the_planar_pair_pass_matches_the_scalar_law() {
        every_law_matches_the_scalar_law(true);
    }

    fn every_law_matches_the_scalar_law(planar: bool) {
        let tangentials = [TangentialKind::Linear, TangentialKind::Mindlin, TangentialKind::MindlinDamped];
        for normal in [NormalKind::Linear, NormalKind::Hertz] {
            for tangential in tangentials {
                for restitution in [1.0, 0.4] {
                    let m = scene(normal, tangential, restitution, planar);
                    let plan = StepPlan::build(&m);
                    assert_eq!(plan.dashpot, restitution < 1.0);
                    for rot in [false, true] {
                        let [lanes, sliding, scalar] = crate::with_laws!(plan, compare[plan.dashpot, rot](&m, &plan));
                        let what = format!("{normal:?} {tangential:?} e {restitution} rot {rot} planar {planar}");
                        // The scene must exercise both paths and the lanes' sliding branch.
                        assert!(lanes > 300 && scalar > 300, "{what}: {lanes} in lanes, {scalar} scalar");
                        assert!(sliding > 30 && sliding < lanes, "{what}: {sliding} of {lanes} sliding");
                    }
                }
            }
        }
    }

    #[test]
    fn lane_rotation_into_the_plane_matches_the_scalar_one_bit_for_bit() {
        use crate::physics::contact_law::rotate_into_plane as scalar;
        let n = Vec3::new(0.3, -0.4, 0.5).normalize();
        let shears = [Vec3::zeros(), n * 2.5, Vec3::new(1e-3, 2e-3, -7e-4), Vec3::new(-0.0, 0.0, -0.0)];
        let rotated = rotate_into_plane(V4::<false>::lanes(|l| shears[l]), &V4::lanes(|_| n));
        for (l, s) in shears.iter().enumerate() {
            assert!(same(rotated.get(l), scalar(*s, &n)), "lane {l}");
        }
    }
}
