// CG iteration, part 1: q = S A c and the partial sums of cᵀq.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_apply(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    if (cg_stopped(lid.x)) {
        return;
    }
    let p = gid.x;
    var cq = 0.0;
    if (p < params.particle_count) {
        let q = filter_of(p, apply_a(W_C, p));
        work[wi(W_Q, p)] = vec4<f32>(q, 0.0);
        cq = dot3(work[wi(W_C, p)].xyz, q);
    }
    reduce_to_partial(cq, lid.x, wg.x, P_CQ);
}
