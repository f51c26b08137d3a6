// Symplectic Euler: v* = v + dt w f, x* = x + dt v* (pinned: x* = x,
// v* = 0). Twin: cpu::explicit::step up to the fix-up.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// Without fix-up, end the step here (twin: finish_step): collide and store
// in place. Either this kernel then reads no other particle's state (the
// general kernels without wind: the spring pass has gathered it), or it
// reads it, wind triangles included, from a snapshot (below).
override FUSED: bool = false;
// Single-pass grid steps (see GpuSolver::step_plan): read every particle's
// state from the `work` sections SNAP_IN (x) and SNAP_IN + 1 (v) that the
// previous step (or explicit_seed) wrote, and write the new state to x, v
// and to SNAP_OUT, SNAP_OUT + 1 — no invocation reads what another writes.
override SNAP_IN: u32 = 0xffffffffu;
override SNAP_OUT: u32 = 0xffffffffu;

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
    var x0: vec4<f32>;
    var v0: vec4<f32>;
    if (SNAP_IN == STATE_BUFFERS) {
        x0 = x[p];
        v0 = v[p];
    } else {
        x0 = work[wi(SNAP_IN, p)];
        v0 = work[wi(SNAP_IN + 1u, p)];
    }
    let w = x0.w;
    let f = total_force(p, x0, v0, SNAP_IN);
    var vn = v0.xyz + f * (params.dt * w);
    var xn = x0.xyz;
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
        let ok = store_state(p, xn, vn, w, v0.w);
        if (SNAP_OUT != STATE_BUFFERS) {
            // The snapshot keeps what store_state kept.
            work[wi(SNAP_OUT, p)] = select(x0, vec4<f32>(xn, w), ok);
            work[wi(SNAP_OUT + 1u, p)] = select(v0, vec4<f32>(vn, v0.w), ok);
        }
        return;
    }
    work[wi(W_X_PRED, p)] = vec4<f32>(xn, 0.0);
    work[wi(W_V_NEW, p)] = vec4<f32>(vn, 0.0);
}
