// CG iteration, part 1: the direction c = s + β c and its product
// q = S A c = S A s + β q (twin: the folded direction update of
// cpu::implicit::step), and cᵀq's term in q's w.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count || cg_done()) {
        return;
    }
    let beta = partials[scalar_index(C_BETA)];
    let t = filter_of(p, apply_a(W_S, p));
    let c = work[wi(W_S, p)].xyz + work[wi(W_C, p)].xyz * beta;
    let q = t + work[wi(W_Q, p)].xyz * beta;
    work[wi(W_C, p)] = vec4<f32>(c, 0.0);
    work[wi(W_Q, p)] = vec4<f32>(q, dot3(c, q));
}
