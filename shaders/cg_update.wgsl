// CG iteration, part 2: Δv += α c; r −= α q; s = S P r, with the next
// ρ = r·(P r)'s term in r's w and the particle's filter kind in s's w
// (for cg_apply, which filters its neighbours' s; cg_update_item). With
// coarse levels (twin: cpu::coarse::Coarse::level1), one invocation per
// level-1 aggregate, which also adds its correction S D⁻¹Πᵀr to s and
// leaves Πᵀr and its term of δ in W_COARSE_Z for cg_beta
// (cg_update_aggregate). The FIRST variant (after cg_init, dispatched
// directly) only preconditions the initial residual.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

override FIRST: bool = false;

@compute @workgroup_size(WORKGROUP)
fn cg_update(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (cg_done()) {
        return;
    }
    // α once per invocation (a load after a store to `work` is not
    // merged with the one before it).
    let alpha = partial(scalar_index(C_ALPHA));
    if (COARSE) {
        if (gid.x < params.coarse.z) {
            cg_update_aggregate(gid.x, alpha, FIRST);
        }
        return;
    }
    let p = gid.x;
    if (p >= params.particle_count) {
        return;
    }
    cg_update_item(p, alpha, FIRST);
}
