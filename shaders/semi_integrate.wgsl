// Semi-implicit step, per particle: v += Δv (free particles), then
// x* = x + dt v as in the explicit scheme; the fix-up and finish_step follow.
#include "common/bindings.wgsl"

@compute @workgroup_size(WORKGROUP)
fn semi_integrate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicStore(&status[STATUS_FIXUP_MOVED], 0u);
        atomicStore(&status[STATUS_FIXUP_STOPPED], 0u);
        atomicStore(&status[STATUS_FIXUP_RESULT], W_X_PRED);
        atomicStore(&status[STATUS_FIXUP_PASSES], 0u);
        atomicStore(&status[STATUS_FIXUP_FLAG], 0u);
        // The scalable filter's CG count (zero with the dense filter).
        atomicMax(&status[STATUS_CG_MAX_ITERATIONS], atomicLoad(&status[STATUS_CG_ITERATIONS]));
    }
    if (p >= params.particle_count) {
        return;
    }
    var vn = vec3<f32>(0.0);
    var xn = x[p].xyz;
    if (x[p].w > 0.0) {
        vn = v[p].xyz + work[wi(W_DV, p)].xyz;
        xn += vn * params.dt;
    }
    work[wi(W_X_PRED, p)] = vec4<f32>(xn, 0.0);
    work[wi(W_V_NEW, p)] = vec4<f32>(vn, 0.0);
}
