// The wall pass and integration in one pass, for plans in which no force stage runs between
// them (walls, no parallel bonds, rolling resistance, pore flow, applied loads or buoyancy): each
// invocation moves the particle it has just finished, with the force and torque it holds,
// instead of a second dispatch reading them back. The same arithmetic as the two passes, bit
// for bit. Compiled after wall_forces.wgsl and integrate.wgsl (backend/gpu/shaders.rs).

@compute @workgroup_size(64)
fn compute_wall_forces_and_integrate(@builtin(global_invocation_id) gid: vec3<u32>,
                                     @builtin(num_workgroups) groups: vec3<u32>,
                                     @builtin(workgroup_id) wg: vec3<u32>,
                                     @builtin(local_invocation_index) li: u32) {
    let p = wall_pass(gid, groups, wg, li);
    if p.inside {
        if p.k == 0u {
            count_step();
        }
        integrate_particle(p.k, p.force, p.torque);
    }
}
