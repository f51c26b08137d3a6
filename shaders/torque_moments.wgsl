// Torque compensation, pass 2: partial sums of the angular impulse not
// explained by external forces, and of the inertia tensor.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/torque.wgsl"

@compute @workgroup_size(WORKGROUP)
fn torque_moments(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    let centre = centre_of_mass(lid.x);
    let p = gid.x;
    var t = array<f32, T_MOMENT_SUMS>();
    if (p < params.particle_count) {
        t = moment_terms(p, centre);
    }
    for (var k = 0u; k < T_MOMENT_SUMS; k++) {
        reduce_to_partial(t[k], lid.x, wg.x, torque_slot(T_EXCESS + k));
    }
}
