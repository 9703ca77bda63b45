// The `wall_forces` stage on the GPU: particle–wall contacts. Each particle tests every wall (a
// scene has at most eight) and adds the contact forces to its own force; each workgroup sums its
// particles' loads on each wall in a fixed tree order and leaves one partial per wall, which the
// walls stage of the next step adds up (walls.wgsl). Runs once per slab; a slab starts on a
// workgroup boundary, so the partials are the same however the particles are split. A wall no
// particle of the workgroup touches has a zero partial, written without a tree, and the walls
// it touches are summed up to four at a time in one tree: a tree costs the workgroup 8
// barriers, and in a large scene most workgroups touch few walls. A wall whose load nothing
// reads before the next pass writes it again (any but a servo, at a step other than a batch's
// last) is left out of the partials by STEP_LOADS; with no wall left, the pass has no touch
// mask, no tree and no barrier at all.
// CPU twin: backend/cpu/wall_forces.rs.

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

// The loads of up to TREES touched walls, summed by one tree together (8 KiB of the 16 KiB a
// workgroup may hold; the walls' trees side by side keep each wall's own order of sums).
const TREES: u32 = 4u;
var<workgroup> red_force: array<array<vec4<f32>, 64>, TREES>;
var<workgroup> red_stiffness: array<array<vec4<f32>, 64>, TREES>;
// Bit w: some particle of the workgroup touches wall w (zero at the start of a dispatch).
var<workgroup> touching: atomic<u32>;
var<workgroup> touching_all: u32;
// Bit w: this pass leaves the workgroups' load partials of wall w (the others' partials are
// left as they were; the particles' forces are the same bits either way).
override STEP_LOADS: u32 = 0xffffffffu;

@compute @workgroup_size(64)
fn compute_wall_forces(@builtin(global_invocation_id) gid: vec3<u32>,
                       @builtin(num_workgroups) groups: vec3<u32>,
                       @builtin(workgroup_id) wg: vec3<u32>,
                       @builtin(local_invocation_index) li: u32) {
    wall_pass(gid, groups, wg, li);
}

// The particle an invocation of the wall pass finished, and its summed force and torque.
struct Finished {
    k: u32,
    inside: bool,
    force: vec3<f32>,
    torque: vec3<f32>,
}

// The pass for one invocation (all of a workgroup's invocations call it: it has barriers).
fn wall_pass(gid: vec3<u32>, groups: vec3<u32>, wg: vec3<u32>, li: u32) -> Finished {
    let local = invocation(gid, groups);
    let nw = params.nw;
    let inside = local < slab.count;
    let kl = min(local, slab.count - 1u);
    let k = slab.first + kl;
    let oi = origin[k].xyz;
    let ri = origin[k].w;
    let ui = disp[k].xyz;
    let vi = vel[k].xyz;
    let mi = body[k].x;
    let mati = kind[k] & 0xffffu;
    var wi = vec3<f32>(0.0);
    var t = vec3<f32>(0.0);
    if ROTATION {
        wi = ang_vel[k].xyz;
        t = torque[k].xyz;
    }
    var f = force[k].xyz;
    let group = slab.first / 64u + wg.x + wg.y * groups.x;
    // This particle's heat (damping, friction) and the work the walls did on it.
    var h = vec3<f32>(0.0);
    // Which walls the workgroup touches: their loads are the only ones to sum.
    var touched = 0u;
    if STEP_LOADS != 0u {
        var mine = 0u;
        for (var w = 0u; w < nw; w++) {
            if inside && (STEP_LOADS & (1u << w)) != 0u && wall_overlap(walls[w], k, oi, ui, ri).overlap > 0.0 {
                mine |= 1u << w;
            }
        }
        if mine != 0u {
            atomicOr(&touching, mine);
        }
        workgroupBarrier();
        if li == 0u {
            touching_all = atomicLoad(&touching);
        }
        touched = workgroupUniformLoad(&touching_all);
    }
    // One wall at a time, in wall order (as the CPU adds them): this particle's contact; the
    // workgroup's loads on the touched walls, TREES walls at a time, summed in a fixed tree
    // order. `queued` and `queue` depend only on `touched`: uniform across the workgroup.
    var queued = 0u;
    var queue = array<u32, TREES>();
    for (var w = 0u; w < nw; w++) {
        // Force on the particle (xyz) and normal load (w); stiffness, contact count and (cone)
        // tip and sleeve loads or (other walls) the dashpot coefficient.
        var load = vec4<f32>(0.0);
        var load2 = vec4<f32>(0.0);
        let wall = walls[w];
        let hit = wall_overlap(wall, k, oi, ui, ri);
        let inward = hit.ng.xyz;
        let overlap = hit.overlap;
        let e = row_slot(kl, w, slab.count);
        if inside {
            let st = wall_state[e];
            if overlap <= 0.0 {
                if any(st != vec4<f32>(0.0)) {
                    // Just opened (the state's w is the dashpot force of the last step).
                    var v_rel = vi - wall_surface_velocity(wall, inward);
                    if ROTATION {
                        v_rel = v_rel + cross(wi, -inward * ri);
                    }
                    let p = wall_pairs[w * params.nmat + mati];
                    let fd = contact_opened(p, ri, st.xyz, st.w, -inward, v_rel, params.dt);
                    h += vec3<f32>(fd.y, fd.x, 0.0);
                    wall_state[e] = vec4<f32>(0.0);
                }
            } else {
                let nrm = -inward;
                let v_wall = wall_surface_velocity(wall, inward);
                var v_rel = vi - v_wall;
                if ROTATION {
                    v_rel = v_rel + cross(wi, nrm * ri);
                }
                let c = contact(nrm, overlap, v_rel, ri, mi, wall_pairs[w * params.nmat + mati], st.xyz, false,
                                st.w, params.dt);
                wall_state[e] = vec4<f32>(c.spring, c.dashpot);
                f += c.force;
                h += vec3<f32>(c.heat_damping, c.heat_friction, dot(c.force, v_wall) * params.dt);
                if ROTATION {
                    t += cross(nrm * ri, c.shear);
                }
                load = vec4<f32>(c.force, max(dot(c.force, inward), 0.0));
                load2 = vec4<f32>(c.stiffness, 1.0, 0.0, 0.0);
                if u32(wall.normal.w) == WALL_CONE {
                    // A cone's axial load (the reaction on the wall) on its face or its rod.
                    let axial = -dot(c.force, wall.normal.xyz);
                    if hit.part == PART_TIP {
                        load2.z = axial;
                    } else if hit.part == PART_SLEEVE {
                        load2.w = axial;
                    }
                } else {
                    // Any other wall: the dashpot coefficient, for the servo's gain.
                    load2.z = c.damping;
                }
            }
        }
        if (STEP_LOADS & (1u << w)) == 0u {
            continue;
        }
        if (touched & (1u << w)) == 0u {
            // Every load is +0: the tree would sum them to +0.
            if li == 0u && group < params.wall_groups {
                partials[(group * nw + w) * 2u] = vec4<f32>(0.0);
                partials[(group * nw + w) * 2u + 1u] = vec4<f32>(0.0);
            }
            continue;
        }
        red_force[queued][li] = load;
        red_stiffness[queued][li] = load2;
        queue[queued] = w;
        queued += 1u;
        // Sum when the trees are full or no touched wall is left.
        if queued < TREES && (touched >> (w + 1u)) != 0u {
            continue;
        }
        workgroupBarrier();
        for (var s = 32u; s > 0u; s >>= 1u) {
            if li < s {
                for (var q = 0u; q < queued; q++) {
                    red_force[q][li] += red_force[q][li + s];
                    red_stiffness[q][li] += red_stiffness[q][li + s];
                }
            }
            workgroupBarrier();
        }
        if li == 0u && group < params.wall_groups {
            for (var q = 0u; q < queued; q++) {
                partials[(group * nw + queue[q]) * 2u] = red_force[q][0];
                partials[(group * nw + queue[q]) * 2u + 1u] = red_stiffness[q][0];
            }
        }
        workgroupBarrier();
        queued = 0u;
    }
    if inside {
        force[k] = vec4<f32>(f, 0.0);
        if ROTATION {
            torque[k] = vec4<f32>(t, 0.0);
        }
        // A wall takes no heat: the particle books all of it.
        book(HEAT_CONTACT_DAMPING, k, h.x);
        book(HEAT_FRICTION, k, h.y);
        book(HEAT_WALL_WORK, k, h.z);
    }
    return Finished(k, inside, f, t);
}

struct WallOverlap {
    // The wall's unit normal into the particles' region and the gap (w).
    ng: vec4<f32>,
    part: u32,
    overlap: f32,
}

// Where particle k (origin o, displacement u, radius r) meets wall `wall`: both loops of the
// pass ask this, so the workgroup's touch mask and the contacts agree bit for bit. Asked twice
// rather than kept: eight walls' answers in private memory would spill to memory, and the
// geometry is a few dozen operations.
fn wall_overlap(wall: Wall, k: u32, o: vec3<f32>, u: vec3<f32>, r: f32) -> WallOverlap {
    let hit = wall_hit(wall, o, u);
    // A killed element never touches a wall (its wall states were cleared when it was killed).
    let overlap = select(r - hit.ng.w, -1.0, (kind[k] & KILLED) != 0u);
    return WallOverlap(hit.ng, hit.part, overlap);
}

// Adds x to particle i's ledger lane `slot` (nothing when the plan has no such lane).
fn book(slot: u32, i: u32, x: f32) {
    if slot != HEAT_OFF && x != 0.0 {
        let k = ledger_index(i, slot, params.n);
        heat[k] = ledger_add(heat[k], x, params.one);
    }
}
