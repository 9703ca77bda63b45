// The `walls` stage on the GPU. One workgroup sums the wall-force partials the workgroups of the
// last step's wall pass left (in a fixed order: deterministic) into each wall's load, then moves
// each wall by one step: a prescribed velocity, or a servo that closes 20% of the stress error per
// step with a gain from the contacts' stiffness and dashpots (planes and rings; a cone is never servo-controlled).
// At the first step after an upload the partials hold
// the model's last loads. CPU twin: Wall::advance in walls.rs.
//
// With more than 256 partials per wall (over 16,384 particles; walls.rs FOLD_PAST),
// `fold_partials` first sums them 64 at a time, in parallel, into `folded`, and the one
// workgroup sums those: its invocations then read one value in 4,096 partials each, where a
// chain of reads one after another (one per 64 partials) made the sum the step's longest serial
// path in a scene of millions.

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

var<workgroup> red_force: array<vec4<f32>, 64>;
var<workgroup> red_stiffness: array<vec4<f32>, 64>;

// Sums red_force and red_stiffness over the workgroup into their entry 0, in a fixed tree order
// (all 64 invocations take part).
fn tree(li: u32) {
    workgroupBarrier();
    for (var s = 32u; s > 0u; s >>= 1u) {
        if li < s {
            red_force[li] += red_force[li + s];
            red_stiffness[li] += red_stiffness[li + s];
        }
        workgroupBarrier();
    }
}

// Entry k of the partials the load sum reads: the folded ones when there are.
fn partial(k: u32) -> vec4<f32> {
    if params.wall_blocks != 0u {
        return folded[k];
    }
    return partials[k];
}

// Sums the partials into each wall's load (all 64 invocations take part).
fn sum_loads(li: u32) {
    let nw = params.nw;
    let groups = select(params.wall_groups, params.wall_blocks, params.wall_blocks != 0u);
    for (var w = 0u; w < nw; w++) {
        var force = vec4<f32>(0.0);
        var stiffness = vec4<f32>(0.0);
        for (var g = li; g < groups; g += 64u) {
            force += partial((g * nw + w) * 2u);
            stiffness += partial((g * nw + w) * 2u + 1u);
        }
        red_force[li] = force;
        red_stiffness[li] = stiffness;
        tree(li);
        if li == 0u {
            // The wall feels the reaction of the forces on the particles.
            walls[w].load = vec4<f32>(-red_force[0].xyz, red_force[0].w);
            walls[w].load2 = red_stiffness[0];
        }
        workgroupBarrier();
    }
}

// Block b of `wall_blocks`: the partials of workgroups 64·b … 64·b + 63 of the wall pass, summed
// per wall in the same tree order as the load sum's, into `folded`.
@compute @workgroup_size(64)
fn fold_partials(@builtin(workgroup_id) wg: vec3<u32>,
                 @builtin(num_workgroups) groups: vec3<u32>,
                 @builtin(local_invocation_index) li: u32) {
    let b = wg.x + wg.y * groups.x;
    // Uniform across the workgroup: a whole workgroup leaves, so every barrier below is reached
    // by all or none.
    if b >= params.wall_blocks {
        return;
    }
    let nw = params.nw;
    let g = b * 64u + li;
    for (var w = 0u; w < nw; w++) {
        var force = vec4<f32>(0.0);
        var stiffness = vec4<f32>(0.0);
        if g < params.wall_groups {
            force = partials[(g * nw + w) * 2u];
            stiffness = partials[(g * nw + w) * 2u + 1u];
        }
        red_force[li] = force;
        red_stiffness[li] = stiffness;
        tree(li);
        if li == 0u {
            folded[(b * nw + w) * 2u] = red_force[0];
            folded[(b * nw + w) * 2u + 1u] = red_stiffness[0];
        }
        workgroupBarrier();
    }
}

// The loads of the last step alone, for the host to read at the end of a run.
@compute @workgroup_size(64)
fn sum_wall_loads(@builtin(local_invocation_index) li: u32) {
    sum_loads(li);
}

// Whether the walls pass sums the last step's loads before it moves the walls: only a servo
// reads them (off without one; a download sums the run's last loads itself).
override SUM_LOADS: bool = true;

@compute @workgroup_size(64)
fn advance_walls(@builtin(local_invocation_index) li: u32) {
    if SUM_LOADS {
        sum_loads(li);
    }
    if li != 0u {
        return;
    }
    let nw = params.nw;
    let dt = params.dt;
    for (var w = 0u; w < nw; w++) {
        var wall = walls[w];
        let motion = u32(wall.motion.x);
        let area = wall.motion.w;
        let stress_now = select(0.0, wall.load.w / area, area > 0.0);
        // Σk + Σc/dt: a move of Δx in one step adds Σc·Δx/dt through the dashpots at once
        // (Wall::servo_stiffness); z holds Σc on planes and rings (a cone is never a servo).
        let stiffness = wall.load2.x + wall.load2.z / dt;
        let max_speed = wall.motion.z;
        var v = vec3<f32>(0.0);
        if motion == 1u {
            v = wall.prescribed.xyz;
        } else if motion == 2u {
            if u32(wall.normal.w) == WALL_PLANE {
                let error_force = (wall.motion.y - stress_now) * area;
                var speed = max_speed;
                if stiffness > 0.0 {
                    speed = 0.2 * error_force / (stiffness * dt);
                }
                v = wall.normal.xyz * clamp(speed, -max_speed, max_speed);
            } else if u32(wall.normal.w) == WALL_CYLINDER {
                let error_force = (stress_now - wall.motion.y) * area;
                var speed = -max_speed;
                if stiffness > 0.0 {
                    speed = 0.2 * error_force / (stiffness * dt);
                }
                v = vec3<f32>(clamp(speed, -max_speed, max_speed), 0.0, 0.0);
            }
        }
        // w keeps a cone's rod end.
        wall.velocity = vec4<f32>(v, wall.velocity.w);
        wall.moved = vec4<f32>(wall.moved.xyz + v * dt, 0.0);
        walls[w] = wall;
    }
}
