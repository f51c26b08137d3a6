// CG iteration, scalars: ρ summed from the w of W_R, δ_new = ρ plus the
// coarse terms, β = δ_new / δ, count the iteration, and stop if ρ has
// converged (one workgroup).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cg_beta(@builtin(local_invocation_id) lid: vec3<u32>) {
    if (cg_stopped(lid.x)) {
        return;
    }
    let rho = sum_w(W_R, P_RS, lid.x);
    let delta = cg_delta(rho, lid.x);
    if (lid.x != 0u) {
        return;
    }
    partials[scalar_index(C_BETA)] = delta / partials[scalar_index(C_DELTA)];
    partials[scalar_index(C_DELTA)] = delta;
    // The direction update of this iteration is only needed by the next.
    let running = rho > params.cg_tolerance_sq * partials[scalar_index(C_DELTA0)];
    beta_slots_next(atomicAdd(&status[STATUS_CG_ITERATIONS], 1u), running);
    if (!running) {
        atomicStore(&status[STATUS_CG_STOPPED], 1u);
        set_cg_args(false);
    }
}
