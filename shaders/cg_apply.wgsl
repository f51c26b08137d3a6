// CG iteration, part 1: q = S A c, and cᵀq's term in q's w.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count || cg_done()) {
        return;
    }
    let q = filter_of(p, apply_a(W_C, p));
    work[wi(W_Q, p)] = vec4<f32>(q, dot3(work[wi(W_C, p)].xyz, q));
}
