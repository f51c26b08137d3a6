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
    var m = 0.0;
    var mx = vec3<f32>(0.0);
    if (p < params.particle_count) {
        m = v[p].w;
        mx = x[p].xyz * m;
    }
    reduce_to_partial(m, lid.x, wg.x, torque_slot(T_MASS));
    reduce_to_partial(mx.x, lid.x, wg.x, torque_slot(T_MX));
    reduce_to_partial(mx.y, lid.x, wg.x, torque_slot(T_MX + 1u));
    reduce_to_partial(mx.z, lid.x, wg.x, torque_slot(T_MX + 2u));
}
