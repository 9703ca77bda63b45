// The `buoyancy` stage on the GPU, a force stage after the others and before `integrate`:
// below the water level, each element adds the buoyant force −ρ_f·V_sub·g (V_sub the
// submerged volume, a spherical cap where the level cuts the element) to its own force lane,
// so local damping sees it, and, with a viscosity, the Stokes drag on the submerged fraction
// as an exponential integrator written as a force: with A the acceleration of every other
// force (this lane after buoyancy, plus gravity) and x = dt/τ, F_d = −m·[v·(1 − e^(−x))/dt +
// A·(1 − φ)], φ = (1 − e^(−x))/x, which makes the leapfrog kick the exact solution of
// dv/dt = A − v/τ over the step (stable for any viscosity). With the ledger's damping slot
// the drag's heat −F_d·v̄·dt (v̄ the mean of the velocity before and the kick's, free
// components) is booked there. No atomics.
// CPU twin: effects/buoyancy/cpu.rs.

struct Water {
    level: f32,
    density: f32,
    // 6π·μ (0 without drag).
    six_pi_mu: f32,
    pad: f32,
}

const PI: f32 = 3.14159265358979;

// Bindings: generated from this stage's list in engine/src/backend/gpu/shaders.rs.

@compute @workgroup_size(64)
fn buoyancy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    let r = origin[i].w;
    let z = origin[i].z + disp[i].z;
    let h = clamp(water.level - (z - r), 0.0, 2.0 * r);
    // A killed element is out of the model: its lane stays empty.
    if h <= 0.0 || (kind[i] & KILLED) != 0u {
        return;
    }
    let v_sub = PI * h * h * (3.0 * r - h) / 3.0;
    let m = body[i].x;
    let g = params.gravity.xyz;
    var f = force[i].xyz - g * (water.density * v_sub);
    if water.six_pi_mu > 0.0 {
        let fraction = v_sub / (4.0 / 3.0 * PI * r * r * r);
        let x = water.six_pi_mu * r * fraction * params.dt / m;
        // 1 − e^(−x) and 1 − φ, by their series (to x⁶, ~1e-8 relative) where f32 would cancel.
        var loss = x * (1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0))));
        var phi_loss = x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0))));
        if x > 0.1 {
            loss = 1.0 - exp(-x);
            phi_loss = 1.0 - loss / x;
        }
        let a = f / m + g;
        let v0 = vel[i].xyz;
        let fd = -(v0 * (loss / params.dt) + a * phi_loss) * m;
        f = f + fd;
        if HEAT_DAMPING != HEAT_OFF {
            // The drag's heat, −F_d·v̄·dt over the free components (effects/buoyancy/cpu.rs' drag_heat).
            let v1 = v0 + (a + fd / m) * params.dt;
            let fixed = kind[i] >> 24u;
            let free = vec3<f32>(select(1.0, 0.0, (fixed & 1u) != 0u), select(1.0, 0.0, (fixed & 2u) != 0u),
                select(1.0, 0.0, (fixed & 4u) != 0u));
            let q = -dot(fd * free, 0.5 * (v0 + v1)) * params.dt;
            let k = ledger_index(i, HEAT_DAMPING, params.n);
            heat[k] = ledger_add(heat[k], q, params.one);
        }
    }
    force[i] = vec4<f32>(f, force[i].w);
}
