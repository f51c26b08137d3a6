// Torque compensation, pass 1: partial sums of m and m x.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/torque.wgsl"

@compute @workgroup_size(WORKGROUP)
fn torque_centre(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    let p = gid.x;
    var t = array<f32, T_CENTRE_SUMS>();
    if (p < params.particle_count) {
        t = centre_terms(p);
    }
    for (var k = 0u; k < T_CENTRE_SUMS; k++) {
        reduce_to_partial(t[k], lid.x, wg.x, torque_slot(T_MASS + k));
    }
}
