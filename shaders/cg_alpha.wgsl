// CG iteration, scalars: α = δ / cᵀq (one workgroup, one invocation). A
// cᵀAc that is not positive means c vanished to rounding: CG stops (twin:
// the CPU's break before the update).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(1)
fn cg_alpha() {
    if (atomicLoad(&status[STATUS_CG_STOPPED]) != 0u) {
        return;
    }
    let cq = sum_partials(P_CQ);
    if (!(finite1(cq) && cq > 0.0)) {
        atomicStore(&status[STATUS_CG_STOPPED], 1u);
        return;
    }
    partials[scalar_index(C_ALPHA)] = partials[scalar_index(C_DELTA)] / cq;
}
