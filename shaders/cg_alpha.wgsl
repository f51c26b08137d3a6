// CG iteration, scalars: α = δ / cᵀq, cᵀq summed from the w of W_Q (one
// workgroup). A cᵀAc that is not positive means c vanished to rounding: CG
// stops (twin: the CPU's break before the update).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cg_alpha(@builtin(local_invocation_id) lid: vec3<u32>) {
    if (cg_stopped(lid.x)) {
        return;
    }
    let cq = sum_w(W_Q, P_CQ, lid.x);
    if (lid.x != 0u) {
        return;
    }
    let running = finite1(cq) && cq > 0.0;
    alpha_slots_next(cg_iteration(), running);
    if (!running) {
        atomicStore(&status[STATUS_CG_STOPPED], 1u);
        set_cg_args(false);
        return;
    }
    partials[scalar_index(C_ALPHA)] = partials[scalar_index(C_DELTA)] / cq;
}
