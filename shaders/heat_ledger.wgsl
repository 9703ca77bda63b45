// The `heat` stage on the device: the energy ledger's slots and its compensated sum.
// Prepended, after common.wgsl, to every stage (the kernels that dissipate book into it; the
// others only see the constants). The slots and their pipeline constants come from the plan
// (engine/src/backend/gpu/heat.rs); a plan without the ledger has HEAT_LANES = 0, every cause
// HEAT_OFF, and a 128-byte placeholder for the lane.

// The heat ledger (engine/src/backend/gpu/heat.rs): per particle, one (hi, lo) pair for each
// cause the plan needs, at heat[ledger_index(i, slot, n)]; a cause that is off has slot HEAT_OFF.
const HEAT_OFF: u32 = 255u;

// Where particle i's pair for cause `slot` lies among n particles: cause by cause (every
// particle's first cause, then the second), so the invocations of a warp book into
// neighbouring words.
fn ledger_index(i: u32, slot: u32, n: u32) -> u32 {
    return slot * n + i;
}
override HEAT_LANES: u32 = 0u;
override HEAT_DAMPING: u32 = 255u;
override HEAT_CONTACT_DAMPING: u32 = 255u;
override HEAT_FRICTION: u32 = 255u;
override HEAT_BREAKAGE: u32 = 255u;
override HEAT_WALL_WORK: u32 = 255u;

// Adds x to a compensated sum: hi carries the total, lo what f32 rounded off it. A step's
// heat is ~1e-6 of the total over 1e5–1e6 steps, so a plain f32 sum would lose most of it;
// two-sum keeps each step's rounding error in lo, and renormalising keeps lo below half an
// ulp of hi: the pair holds ~48 bits. Two-sum's error terms are zero in real arithmetic, and
// drivers do simplify them away (Mesa's lavapipe does): each step is multiplied by
// `params.one`, which no real-arithmetic rewrite can cancel, and is exact in IEEE f32. It
// comes in as `one` because not every stage that includes this file binds `params`.
fn ledger_add(acc: vec2<f32>, x: f32, one: f32) -> vec2<f32> {
    let s = (acc.x + x) * one;
    let b = (s - acc.x) * one;
    let err = (acc.x - (s - b) * one) * one + (x - b) * one;
    let lo = (acc.y + err) * one;
    let hi = (s + lo) * one;
    return vec2<f32>(hi, (lo - (hi - s) * one) * one);
}
