// Shared by every GPU stage: the scene constants, the lane layout and the contact law.
// This file is prepended to each stage's source (see engine/src/backend/gpu/shaders.rs).
//
// Positions are split into a per-upload origin and the displacement since (both f32), so a
// step's move of 1e-9 m is not lost against a coordinate of 0.05 m, and the distance of two
// neighbours is computed from the small differences of both parts.

// The plan's choices, fixed when a pipeline is built: a switched-off effect is folded away.
override NORMAL_HERTZ: bool = false;
override MINDLIN: bool = false;
// Mindlin's spring with a tangential dashpot (MindlinDampedShear); meaningful with DASHPOT.
override TANGENTIAL_DASHPOT: bool = false;
override DASHPOT: bool = false;
override ROTATION: bool = false;
override VISCOUS: bool = false;
override LOCAL: bool = false;
// The epsd rolling resistance model: rows carry a rolling spring per entry (rolling_resistance.wgsl).
override ROLLING_SPRING: bool = false;
// A 2D model (every centre at y = 0): the neighbour search visits one layer of cells, and
// the contact pass reads its vectors through `in_plane` and `about_y`.
override PLANAR: bool = false;
// Clumps exist: the neighbour search leaves out pairs within one clump (its `clump_of` lane).
override CLUMPS: bool = false;
// A periodic cell: pairs meet through their nearest image (periodic_image.wgsl).
override PERIODIC: bool = false;
// The periodic cell shears by Lees–Edwards images (x along z): the images across the z faces
// are shifted along x and slide (periodic_image.wgsl, `params.shear`).
override SHEAR: bool = false;

const WALL_PLANE: u32 = 0u;
const WALL_CYLINDER: u32 = 1u;
const WALL_CONE: u32 = 2u;
const WALL_STRIP: u32 = 3u;
// The parts of a wall a contact touches (WallPart in walls.rs).
const PART_WHOLE: u32 = 0u;
const PART_TIP: u32 = 1u;
const PART_SLEEVE: u32 = 2u;
const PART_CAP: u32 = 3u;
const MAX_WALLS: u32 = 8u;
// The `kind` lane's bit of a killed element (dof::KILLED << 24, Model::kill): in no row and
// touching no wall. Its other fixity bits are set too, so the integrator keeps it at rest.
const KILLED: u32 = 0x40000000u;
// The `kind` lane's bit of a clump's member (dof::CLUMPED << 24): moved by its clump (the
// `clumps` stage), not by the integrator; in no row with a member of its own clump.
const CLUMPED: u32 = 0x80000000u;

// Slots of the counters buffer.
const C_STEP: u32 = 0u;
const C_EVENTS: u32 = 1u;
const C_DRIFT: u32 = 2u;
const C_SPEED: u32 = 3u;
const C_GUARD: u32 = 4u; // four slots: non-finite, too fast, overlap, through a wall
const C_LONGEST: u32 = 8u; // the longest row a device build found
const C_CROWDED: u32 = 9u; // rows with more set states than a device build carries
const C_STIFF: u32 = 10u; // the lowest particle in a contact too stiff for dt (guard.wgsl)
const C_PORE_STEP: u32 = 11u; // the batch's smallest stable flow step V/(K_f·Σg), f32 bits (pore_flow.wgsl)
const C_PORE_DRIFT: u32 = 12u; // the largest squared drift since the pore network's build, f32 bits
const C_PORE_EXCHANGE: u32 = 13u; // the batch's smallest stable step of the fluid–grain heat exchange, f32 bits (pore_heat.wgsl)

struct Params {
    n: u32,
    nw: u32,
    nmat: u32,
    max_events: u32,
    dt: f32,
    local_damping: f32,
    max_overlap_ratio: f32,
    wall_groups: u32,
    gravity: vec4<f32>,
    // Entries each row has room for. A slab's rows lie rank by rank: entry k of the slab's
    // particle `local` is at k·count + local (`row_slot`).
    cap: u32,
    // Buckets of the cell list's hash table (a power of two).
    buckets: u32,
    // Search distance beyond touching, and the cell list's cell size (at least 2·r_max + skin).
    skin: f32,
    cell: f32,
    // 1.0, which the shader compiler cannot know (see ledger_add).
    one: f32,
    // Blocks of 64 wall-load partials the walls stage folds first; 0: it sums them directly.
    wall_blocks: u32,
    // A periodic cell's spans (0 on an axis that does not repeat), their inverses (0 there too)
    // and lower faces (periodic_image.wgsl).
    period: vec4<f32>,
    period_inv: vec4<f32>,
    period_lo: vec4<f32>,
    // Lees–Edwards shear (SHEAR): the offset of the images one cell up during this step's
    // stages, the offset after this step's advance (the periodic stage's wrap), and their
    // slide γ̇·L_z (m/s); a copy from the step's schedule writes it before each step.
    shear: vec4<f32>,
}

// The particles a dispatch of a per-entry kernel covers: the per-entry lanes (rows, pair
// and wall contact states, pair dashpot forces) are bound one slab at a time (memory.rs).
struct Slab {
    first: u32,
    count: u32,
    pad0: u32,
    pad1: u32,
}

// Where entry k of the row of a slab's particle `local` lies, in a slab of `count` particles
// (and its contact state with wall k: the wall contact states lie wall by wall the same way).
// Rows lie rank by rank (entry 0 of every row, then entry 1, …): the invocations of a warp hold
// neighbouring rows, so at each entry they read neighbouring words, where rows one after another
// put their reads a whole row apart.
fn row_slot(local: u32, k: u32, count: u32) -> u32 {
    return k * count + local;
}

// One past the slot of the last of `len` entries of `local`'s row (the row's entries are
// `local`, `local + count`, …, below it).
fn row_end(local: u32, len: u32, count: u32) -> u32 {
    return row_slot(local, len, count);
}

// The cell of the device's cell list holding position `x` (cells of `size`, which is at
// least the longest reach, so a row's neighbours are in the 27 cells around its own).
fn cell_of(x: vec3<f32>, size: f32) -> vec3<i32> {
    return vec3<i32>(floor(x / size));
}

// The bucket of a cell in a table of `buckets` (a power of two): cells are unbounded, the
// table is not, so distant cells share buckets (harmless: a row tests every candidate's
// distance).
fn bucket_of(c: vec3<i32>, buckets: u32) -> u32 {
    let u = bitcast<vec3<u32>>(c);
    return ((u.x * 73856093u) ^ (u.y * 19349663u) ^ (u.z * 83492791u)) & (buckets - 1u);
}

// The invocation's index within its dispatch (a 2-D grid of workgroups of 64).
fn invocation(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

// Pair constants (PairParams in physics/contact_law.rs), 48 bytes.
struct Pair {
    kn: f32,
    ks: f32,
    breaking_force: f32,
    fs0: f32,
    mu: f32,
    e_star: f32,
    g_star: f32,
    zeta: f32,
    alpha: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

// A wall (walls.rs): the shape at upload, its motion and the loads of the last step.
struct Wall {
    // Plane, strip: a point; cylinder: the axis point, radius in w; cone: the apex, base radius
    // in w; strip: its axis's x in w.
    point: vec4<f32>,
    // Unit normal into the particles' region (cone: the unit axis from the apex towards the
    // rod); w = shape (WALL_PLANE, WALL_CYLINDER, WALL_CONE, WALL_STRIP).
    normal: vec4<f32>,
    // x = 0 fixed, 1 prescribed velocity, 2 servo; y = target stress; z = max speed; w = area.
    // A strip (never a servo) keeps its ends lo and hi along its axis in y and z.
    motion: vec4<f32>,
    // Prescribed velocity; w = a cone's length along its axis (radius / tan(half-angle)), a
    // strip's axis's y.
    prescribed: vec4<f32>,
    // Velocity during the last step; w = a cone's rod end along its axis (length + rod), a
    // strip's axis's z.
    velocity: vec4<f32>,
    // Moved since upload (a cylinder's radius change is x).
    moved: vec4<f32>,
    // Force the particles exert on the wall (xyz) and the summed normal force (w).
    load: vec4<f32>,
    // x = summed normal stiffness, y = contacts; a cone's axial load on its face (z) and its
    // rod (w); any other wall's summed normal dashpot coefficient (z), for the servo's gain.
    load2: vec4<f32>,
}

// One contact evaluated for one row.
struct Contact {
    force: vec3<f32>,
    // Tangential force on this element (spring + dashpot), for the torque.
    shear: vec3<f32>,
    // The shear spring's force, the pair state to keep.
    spring: vec3<f32>,
    bonded: bool,
    // 0 none, 1 tension, 2 shear (BreakKind).
    broke: u32,
    stiffness: f32,
    // Normal dashpot coefficient (N·s/m; 0 unless DASHPOT), for servo gains.
    damping: f32,
    // Heat of the whole pair this step (J), by cause, as the CPU's ContactResult books it.
    heat_damping: f32,
    heat_friction: f32,
    heat_breakage: f32,
    // Dashpot force of this step (N), for the next step's trapezoid (0 unless DASHPOT).
    dashpot: f32,
}

fn hertz_constant(e_star: f32, r_star: f32) -> f32 {
    return 4.0 / 3.0 * e_star * sqrt(r_star);
}

fn normal_force(p: Pair, r_star: f32, overlap: f32) -> f32 {
    if NORMAL_HERTZ {
        return hertz_constant(p.e_star, r_star) * overlap * sqrt(overlap);
    }
    return p.kn * overlap;
}

fn normal_stiffness(p: Pair, r_star: f32, overlap: f32) -> f32 {
    if NORMAL_HERTZ {
        return 1.5 * hertz_constant(p.e_star, r_star) * sqrt(overlap);
    }
    return p.kn;
}

fn dashpot_coefficient(p: Pair, r_star: f32, m_star: f32, overlap: f32) -> f32 {
    if NORMAL_HERTZ {
        return p.alpha * sqrt(m_star * hertz_constant(p.e_star, r_star)) * sqrt(sqrt(overlap));
    }
    return 2.0 * p.zeta * sqrt(p.kn * m_star);
}

fn shear_stiffness(p: Pair, r_star: f32, overlap: f32) -> f32 {
    if MINDLIN {
        return 8.0 * p.g_star * sqrt(r_star * max(overlap, 0.0));
    }
    return p.ks;
}

// Tangential dashpot coefficient 2·√(5/6)·ζ·√(kt·m*) (MindlinDampedShear::dashpot).
fn tangential_dashpot(p: Pair, m_star: f32, kt: f32) -> f32 {
    return 1.8257419 * p.zeta * sqrt(kt * m_star);
}

// Keeps the shear force's magnitude while turning it into the plane normal to n.
fn rotate_into_plane(s: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let s2 = dot(s, s);
    if s2 == 0.0 {
        return s;
    }
    let q = s - n * dot(n, s);
    let q2 = dot(q, q);
    if q2 == 0.0 {
        return vec3<f32>(0.0);
    }
    return q * sqrt(s2 / q2);
}

// MatDEM's linear elastic-brittle bonded contact with the scene's normal law, a shear spring
// with a Coulomb cap and an optional normal dashpot: `contact` in physics/contact_law.rs,
// line for line, heat included. Every operation is odd in (n, v_rel, shear) and the heat is
// even, so the two rows of a pair compute opposite forces and the same heat. `dashpot_in`
// is the dashpot force of the last step. Call only when bonded or overlapping.
fn contact(n: vec3<f32>, overlap: f32, v_rel: vec3<f32>, r_star: f32, m_star: f32, p: Pair,
           shear_in: vec3<f32>, bonded_in: bool, dashpot_in: f32, dt: f32) -> Contact {
    var out: Contact;
    out.bonded = bonded_in;
    out.broke = 0u;
    let touching = overlap > 0.0;
    var fn_el = p.kn * overlap;
    var kn = p.kn;
    if touching {
        fn_el = normal_force(p, r_star, overlap);
        kn = normal_stiffness(p, r_star, overlap);
    }
    out.stiffness = kn;
    let vn = dot(v_rel, n);
    let kt = shear_stiffness(p, r_star, overlap);
    let vt = v_rel - n * vn;
    let s_prev = rotate_into_plane(shear_in, n);
    var s = s_prev - vt * (kt * dt);
    if bonded_in && fn_el < -p.breaking_force {
        out.heat_breakage = bond_tension_release(p, overlap, vn, dt) + released(s, vec3<f32>(0.0), s_prev, kt);
        out.heat_damping = 0.5 * dashpot_in * vn * dt;
        out.broke = 1u;
        out.bonded = false;
        out.shear = vec3<f32>(0.0);
        out.spring = vec3<f32>(0.0);
        out.force = vec3<f32>(0.0);
        return out;
    }
    var fn_total = fn_el;
    if DASHPOT && touching {
        out.damping = dashpot_coefficient(p, r_star, m_star, overlap);
        let f_dash = out.damping * vn;
        fn_total += f_dash;
        // The trapezoid over the step, as on the CPU.
        out.heat_damping = 0.5 * (dashpot_in + f_dash) * vn * dt;
        out.dashpot = f_dash;
    } else if DASHPOT {
        out.heat_damping = 0.5 * dashpot_in * vn * dt;
    }
    // Tangential dashpot, capped with the spring (as on the CPU; its heat c_t·|v_t|²·dt).
    var f_td = vec3<f32>(0.0);
    var heat_td = 0.0;
    if TANGENTIAL_DASHPOT && DASHPOT && touching {
        f_td = vt * -tangential_dashpot(p, m_star, kt);
        heat_td = -dot(f_td, vt) * dt;
        out.heat_damping += heat_td;
    }
    var total = s;
    if TANGENTIAL_DASHPOT {
        total = s + f_td;
    }
    var limit = p.mu * max(fn_el, 0.0);
    if out.bonded {
        limit = max(p.fs0 + p.mu * fn_el, 0.0);
    }
    let s2 = dot(total, total);
    // The dashpot force the element feels: clipped to the cap when the contact slides.
    var f_felt = f_td;
    if s2 > limit * limit {
        if out.bonded {
            // The bond fails in shear; from now on only friction holds.
            out.bonded = false;
            out.broke = 2u;
            limit = p.mu * max(fn_el, 0.0);
            if !touching {
                out.heat_breakage = bond_tension_release(p, overlap, vn, dt);
                fn_total = 0.0;
            }
        }
        if s2 > limit * limit {
            var capped = s * (limit / sqrt(s2));
            if TANGENTIAL_DASHPOT {
                // The total is scaled to the cap and the spring keeps the rest; a dashpot that
                // alone exceeds the cap is clipped to it first (as on the CPU).
                let d2 = dot(f_td, f_td);
                if d2 > limit * limit {
                    f_felt = f_td * (limit / sqrt(d2));
                }
                capped = total * (limit / sqrt(s2)) - f_felt;
            }
            if out.broke != 0u {
                out.heat_breakage += released(s, capped, s_prev, kt);
            } else if TANGENTIAL_DASHPOT {
                // Sliding: spring and dashpot together dissipate friction heat (as on the CPU).
                let slip = released_signed(s, capped, s_prev, kt) - dot(f_felt, vt) * dt;
                out.heat_friction = max(slip, 0.0);
                out.heat_damping += min(slip, 0.0) - heat_td;
            } else {
                out.heat_friction = released(s, capped, s_prev, kt);
            }
            s = capped;
        }
    }
    // The pair state keeps the spring; the element feels spring + dashpot.
    out.spring = s;
    out.shear = s;
    if TANGENTIAL_DASHPOT {
        out.shear = s + f_felt;
    }
    out.force = out.shear - n * fn_total;
    return out;
}

// A particle against a wall: the unit normal into the particles' region and the gap
// (`ng`, as wall_normal_and_gap) and the part touched (PART_*).
struct WallHit {
    ng: vec4<f32>,
    part: u32,
}

// A cone and rod (WallShape::Cone, `cone_profile_distance` in walls.rs): the nearest point of
// the body of revolution to a particle whose origin is `o` and displacement `u`.
fn cone_hit(w: Wall, o: vec3<f32>, u: vec3<f32>) -> WallHit {
    let axis = w.normal.xyz;
    let radius = w.point.w;
    let h = w.prescribed.w;
    let end = w.velocity.w;
    let d = (o - w.point.xyz) + (u - w.moved.xyz);
    let s = dot(d, axis);
    let q = d - axis * s;
    let rho = length(q);
    var e: vec3<f32>;
    if rho > 0.0 {
        e = q / rho;
    } else {
        // On the axis: a direction across it fixed by the axis alone (`across` in walls.rs).
        var helper = vec3<f32>(0.0, 1.0, 0.0);
        if abs(axis.x) < 0.9 {
            helper = vec3<f32>(1.0, 0.0, 0.0);
        }
        e = normalize(cross(axis, helper));
    }
    let slant = length(vec2<f32>(h, radius));
    let n_face = vec2<f32>(-radius / slant, h / slant);
    let f_face = n_face.x * s + n_face.y * rho;
    let f_rod = rho - radius;
    let f_cap = s - end;
    var n = vec2<f32>(0.0);
    var gap = 0.0;
    var part = PART_TIP;
    if f_face <= 0.0 && f_rod <= 0.0 && f_cap <= 0.0 {
        // Inside: the nearest line.
        if f_face >= f_rod && f_face >= f_cap {
            n = n_face;
            gap = f_face;
        } else if f_rod >= f_cap {
            n = vec2<f32>(0.0, 1.0);
            gap = f_rod;
            part = PART_SLEEVE;
        } else {
            n = vec2<f32>(1.0, 0.0);
            gap = f_cap;
            part = PART_CAP;
        }
    } else {
        // Outside: the nearest of the three profile segments (a tie goes to the first).
        let t = clamp((s * h + rho * radius) / (slant * slant), 0.0, 1.0);
        var c = array<vec2<f32>, 3>(vec2<f32>(t * h, t * radius), vec2<f32>(clamp(s, h, end), radius),
                                    vec2<f32>(end, clamp(rho, 0.0, radius)));
        var edge = array<vec2<f32>, 3>(n_face, vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0));
        gap = 3.4e38;
        for (var k = 0u; k < 3u; k++) {
            let dv = vec2<f32>(s, rho) - c[k];
            let dist = length(dv);
            if dist < gap {
                gap = dist;
                if dist > 0.0 {
                    n = dv / dist;
                } else {
                    n = edge[k];
                }
                part = PART_TIP + k;
            }
        }
    }
    return WallHit(vec4<f32>(axis * n.x + e * n.y, gap), part);
}

// wall_normal_and_gap with the part touched.
fn wall_hit(w: Wall, o: vec3<f32>, u: vec3<f32>) -> WallHit {
    if u32(w.normal.w) == WALL_CONE {
        return cone_hit(w, o, u);
    }
    return WallHit(wall_normal_and_gap(w, o, u), PART_WHOLE);
}

// Unit normal into the particles' region and the gap from wall `w` to a particle whose
// origin is `o` and displacement `u` (positive inside).
fn wall_normal_and_gap(w: Wall, o: vec3<f32>, u: vec3<f32>) -> vec4<f32> {
    if u32(w.normal.w) == WALL_CONE {
        return cone_hit(w, o, u).ng;
    }
    if u32(w.normal.w) == WALL_STRIP {
        return strip_normal_and_gap(w, o, u);
    }
    if u32(w.normal.w) == WALL_CYLINDER {
        let rho = vec2<f32>(o.x - w.point.x, o.y - w.point.y) + u.xy;
        let len = length(rho);
        if len > 0.0 {
            return vec4<f32>(-rho.x / len, -rho.y / len, 0.0, (w.point.w + w.moved.x) - len);
        }
        return vec4<f32>(1.0, 0.0, 0.0, w.point.w + w.moved.x);
    }
    let nrm = w.normal.xyz;
    return vec4<f32>(nrm, dot(o - w.point.xyz, nrm) + dot(u - w.moved.xyz, nrm));
}

// A plane strip (WallShape::Strip, `strip_profile_distance` in walls.rs): the face of a solid
// slab behind the plane between lo and hi along the strip's axis; beyond an end a grain touches
// the end's face, off a corner the corner's edge.
fn strip_normal_and_gap(w: Wall, o: vec3<f32>, u: vec3<f32>) -> vec4<f32> {
    let nrm = w.normal.xyz;
    let axis = vec3<f32>(w.point.w, w.prescribed.w, w.velocity.w);
    let lo = w.motion.y;
    let hi = w.motion.z;
    let d = (o - w.point.xyz) + (u - w.moved.xyz);
    let s = dot(d, axis);
    let h = dot(d, nrm);
    if h <= 0.0 && s >= lo && s <= hi {
        let to_hi = s - hi;
        let to_lo = lo - s;
        if h >= to_hi && h >= to_lo {
            return vec4<f32>(nrm, h);
        } else if to_hi >= to_lo {
            return vec4<f32>(axis, to_hi);
        }
        return vec4<f32>(-axis, to_lo);
    }
    var ds = 0.0;
    if s > hi {
        ds = s - hi;
    } else if s < lo {
        ds = s - lo;
    }
    let dh = max(h, 0.0);
    let dist = sqrt(ds * ds + dh * dh);
    if dist > 0.0 {
        return vec4<f32>((axis * ds + nrm * dh) / dist, dist);
    }
    return vec4<f32>(nrm, 0.0);
}

// Velocity of a wall's surface.
fn wall_surface_velocity(w: Wall, inward: vec3<f32>) -> vec3<f32> {
    if u32(w.normal.w) == WALL_CYLINDER {
        // A growing ring moves its surface outwards, against the inward normal.
        return -inward * w.velocity.x;
    }
    return w.velocity.xyz;
}

// Energy a spring of stiffness k releases when its force drops within a step from `trial` to
// `kept`, having carried `prev` the step before (`released` in physics/contact_law.rs).
fn released(trial: vec3<f32>, kept: vec3<f32>, prev: vec3<f32>, k: f32) -> f32 {
    return max(released_signed(trial, kept, prev, k), 0.0);
}

// `released` without the floor at zero (`released_signed`).
fn released_signed(trial: vec3<f32>, kept: vec3<f32>, prev: vec3<f32>, k: f32) -> f32 {
    if k > 0.0 {
        return 0.5 * dot(trial - kept, kept + prev) / k;
    }
    return 0.0;
}

// Energy a bond stretched in tension releases when it breaks (`bond_tension_release`).
fn bond_tension_release(p: Pair, overlap: f32, vn: f32, dt: f32) -> f32 {
    if overlap < 0.0 {
        return max(0.5 * p.kn * overlap * (overlap - vn * dt), 0.0);
    }
    return 0.0;
}

// Heat of a contact that opened this step (`contact_opened`): the shear spring lets go
// (friction, x) and the last dashpot force works over this step (damping, y). Whole pair.
fn contact_opened(p: Pair, r_star: f32, shear_in: vec3<f32>, dashpot_in: f32, n: vec3<f32>, v_rel: vec3<f32>,
                  dt: f32) -> vec2<f32> {
    let vn = dot(v_rel, n);
    let kt = shear_stiffness(p, r_star, 0.0);
    let s_prev = rotate_into_plane(shear_in, n);
    let trial = s_prev - (v_rel - n * vn) * (kt * dt);
    return vec2<f32>(released(trial, vec3<f32>(0.0), s_prev, kt), 0.5 * dashpot_in * vn * dt);
}

// A 2D model's positions, velocities and springs lie in the x–z plane and its spins point
// along y: read through these, the components that are zero there become the literal 0.0
// once the pipeline is built, so the compiler can drop their arithmetic from the pair loop.
// (For a 3D model they are the identity.)
fn in_plane(v: vec3<f32>) -> vec3<f32> {
    if PLANAR {
        return vec3<f32>(v.x, 0.0, v.z);
    }
    return v;
}

fn about_y(w: vec3<f32>) -> vec3<f32> {
    if PLANAR {
        return vec3<f32>(0.0, w.y, 0.0);
    }
    return w;
}
