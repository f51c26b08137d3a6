// Symplectic Euler: v* = v + dt w f, x* = x + dt v* (pinned: x* = x,
// v* = 0). Twin: cpu::explicit::step up to the fix-up.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// Without fix-up and wind, end the step here (twin: finish_step): collide
// and store in place — this kernel then reads no other particle's state.
override FUSED: bool = false;

@compute @workgroup_size(WORKGROUP)
fn explicit_integrate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicAdd(&status[STATUS_STEP], 1u);
        atomicStore(&status[STATUS_FIXUP_MOVED], 0u);
        atomicStore(&status[STATUS_FIXUP_STOPPED], 0u);
        atomicStore(&status[STATUS_FIXUP_RESULT], W_X_PRED);
        atomicStore(&status[STATUS_FIXUP_PASSES], 0u);
        atomicStore(&status[STATUS_FIXUP_FLAG], 0u);
    }
    if (p >= params.particle_count) {
        return;
    }
    let w = x[p].w;
    let f = total_force(p);
    var vn = v[p].xyz + f * (params.dt * w);
    var xn = x[p].xyz;
    if (w > 0.0) {
        xn += vn * params.dt;
    } else {
        vn = vec3<f32>(0.0);
    }
    if (FUSED) {
        if (w > 0.0) {
            let r = collide_particle(xn, vn);
            xn = r[0];
            vn = r[1];
        }
        store_state(p, xn, vn);
        return;
    }
    work[wi(W_X_PRED, p)] = vec4<f32>(xn, 0.0);
    work[wi(W_V_NEW, p)] = vec4<f32>(vn, 0.0);
}
