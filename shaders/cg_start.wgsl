// CG scalars, once per solve (one workgroup): δ0 from the w of W_RHS, ρ
// from the w of W_R and δ = ρ plus the coarse terms, in the CPU's order,
// and whether CG is done before its first iteration (twin:
// cpu::cg::start).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cg_start(@builtin(local_invocation_id) lid: vec3<u32>) {
    let delta0 = sum_w(W_RHS, P_D0, lid.x);
    let rho = sum_w(W_R, P_RS, lid.x);
    let delta = cg_delta(rho, lid.x);
    if (lid.x != 0u) {
        return;
    }
    partials[scalar_index(C_DELTA0)] = delta0;
    partials[scalar_index(C_DELTA)] = delta;
    partials[scalar_index(C_BETA)] = 0.0;
    let running = rho > params.cg_tolerance_sq * delta0;
    if (!running) {
        atomicStore(&status[STATUS_CG_STOPPED], 1u);
    }
    set_cg_args(running);
    start_slots(running);
}
