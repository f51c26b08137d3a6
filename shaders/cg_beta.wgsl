// CG iteration, scalars: ρ summed from the w of W_R, δ_new = ρ plus the
// coarse terms, β = δ_new / δ, count the iteration, and stop if ρ has
// converged (one workgroup; cg_beta_scalars, twin: cpu::cg::beta).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cg_beta(@builtin(local_invocation_id) lid: vec3<u32>) {
    if (cg_stopped(lid.x)) {
        return;
    }
    let done = cg_beta_scalars(lid.x, COARSE);
    if (lid.x != 0u) {
        return;
    }
    // The direction update of this iteration is only needed by the next.
    beta_slots_next(done.iteration, done.running);
}
