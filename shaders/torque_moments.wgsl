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
    var moment = vec3<f32>(0.0);
    var t = array<f32, 6>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    if (p < params.particle_count) {
        let m = v[p].w;
        let r = x[p].xyz - centre;
        moment = cross3(r, work[wi(W_DV, p)].xyz * m - external_force(p) * params.dt);
        // Twin: Sym3::add_iso_aniso(m |r|², −m, r) on a zero matrix.
        let a = m * dot3(r, r);
        let b = -m;
        t = array<f32, 6>(
            a + b * r.x * r.x,
            a + b * r.y * r.y,
            a + b * r.z * r.z,
            b * r.x * r.y,
            b * r.x * r.z,
            b * r.y * r.z,
        );
    }
    reduce_to_partial(moment.x, lid.x, wg.x, torque_slot(T_EXCESS));
    reduce_to_partial(moment.y, lid.x, wg.x, torque_slot(T_EXCESS + 1u));
    reduce_to_partial(moment.z, lid.x, wg.x, torque_slot(T_EXCESS + 2u));
    for (var k = 0u; k < 6u; k++) {
        reduce_to_partial(t[k], lid.x, wg.x, torque_slot(T_INERTIA + k));
    }
}
