// Torque compensation, pass 3: Δv −= ω × r with ω = I⁻¹ ΔL.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/torque.wgsl"

@compute @workgroup_size(WORKGROUP)
fn torque_apply(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
) {
    let centre = centre_of_mass(lid.x);
    let omega = torque_omega(lid.x);
    let p = gid.x;
    if (p < params.particle_count && omega.w != 0.0) {
        remove_rotation(p, omega.xyz, centre);
    }
}
