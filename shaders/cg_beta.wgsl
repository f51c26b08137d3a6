// CG iteration, scalars: δ_new summed from the w of W_S, β = δ_new / δ,
// count the iteration, and stop if converged (one workgroup).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_beta(@builtin(local_invocation_id) lid: vec3<u32>) {
    if (cg_stopped(lid.x)) {
        return;
    }
    let delta = sum_w(W_S, P_RS, lid.x);
    if (lid.x != 0u) {
        return;
    }
    partials[scalar_index(C_BETA)] = delta / partials[scalar_index(C_DELTA)];
    partials[scalar_index(C_DELTA)] = delta;
    atomicAdd(&status[STATUS_CG_ITERATIONS], 1u);
    // The direction update of this iteration is only needed by the next.
    if (!(delta > params.cg_tolerance_sq * partials[scalar_index(C_DELTA0)])) {
        atomicStore(&status[STATUS_CG_STOPPED], 1u);
        set_cg_args(false);
    }
}
