// The `buoyancy` stage on the GPU: below the water level, the buoyant force −ρ_f·V_sub·g
// (V_sub the submerged volume, a spherical cap where the level cuts the element) finishes the
// step after integration as if the core had integrated it with the other forces (velocity and
// position), and Stokes drag −6π·μ·r·v on the submerged fraction is integrated exactly over
// the step. Blocked components are untouched.
// CPU twin: backend/cpu/buoyancy.rs.

struct Water {
    level: f32,
    density: f32,
    // 6π·μ (0 without drag).
    six_pi_mu: f32,
    pad: f32,
}

const PI: f32 = 3.14159265358979;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> origin: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> disp: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> body: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> kind: array<u32>;
@group(0) @binding(5) var<storage, read_write> vel: array<vec4<f32>>;
@group(0) @binding(6) var<uniform> water: Water;

@compute @workgroup_size(64)
fn buoyancy(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = invocation(gid, groups);
    if i >= params.n {
        return;
    }
    let r = origin[i].w;
    let z = origin[i].z + disp[i].z;
    let h = clamp(water.level - (z - r), 0.0, 2.0 * r);
    if h <= 0.0 {
        return;
    }
    let v_sub = PI * h * h * (3.0 * r - h) / 3.0;
    let m = body[i].x;
    let dt = params.dt;
    // The semi-implicit viscous damping's factor 1/(1 + c·dt/(2m)) (body.y = c/m).
    let kf = 1.0 / (1.0 + 0.5 * body[i].y * dt);
    let g = params.gravity.xyz;
    let b = -g * (water.density * v_sub / m);
    let fraction = v_sub / (4.0 / 3.0 * PI * r * r * r);
    let x = water.six_pi_mu * r * fraction * dt / m;
    let decay = exp(-x);
    // (1 − e^(−x))/x, by its series where f32 would cancel.
    var phi = 1.0 - x / 2.0 + x * x / 6.0;
    if x > 1e-3 {
        phi = (1.0 - decay) / x;
    }
    let v1 = vel[i].xyz;
    var v = v1 * decay - g * (dt * kf * decay) + (g + b) * (dt * kf * phi);
    let fixed = kind[i] >> 24u;
    if (fixed & 1u) != 0u {
        v.x = v1.x;
    }
    if (fixed & 2u) != 0u {
        v.y = v1.y;
    }
    if (fixed & 4u) != 0u {
        v.z = v1.z;
    }
    vel[i] = vec4<f32>(v, vel[i].w);
    disp[i] = vec4<f32>(disp[i].xyz + (v - v1) * dt, disp[i].w);
}
