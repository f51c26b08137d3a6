// CG iteration, scalars: δ_new from the partials, β = δ_new / δ, count the
// iteration, and stop if converged (one workgroup, one invocation).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(1)
fn cg_beta() {
    if (atomicLoad(&status[STATUS_CG_STOPPED]) != 0u) {
        return;
    }
    let delta = sum_partials(P_RS);
    partials[scalar_index(C_BETA)] = delta / partials[scalar_index(C_DELTA)];
    partials[scalar_index(C_DELTA)] = delta;
    atomicAdd(&status[STATUS_CG_ITERATIONS], 1u);
    // The direction update of this iteration is only needed by the next.
    if (!(delta > params.cg_tolerance_sq * partials[scalar_index(C_DELTA0)])) {
        atomicStore(&status[STATUS_CG_STOPPED], 1u);
    }
}
