// CG iteration, part 2: Δv += α c; r −= α q; s = S P r, and the next
// δ = r·(P r)'s term in s's w.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_update(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count || cg_done()) {
        return;
    }
    let alpha = partials[scalar_index(C_ALPHA)];
    let dv = work[wi(W_DV, p)].xyz + work[wi(W_C, p)].xyz * alpha;
    let r = work[wi(W_R, p)].xyz - work[wi(W_Q, p)].xyz * alpha;
    let s = precond_mul(p, r);
    work[wi(W_DV, p)] = vec4<f32>(dv, 0.0);
    work[wi(W_R, p)] = vec4<f32>(r, 0.0);
    work[wi(W_S, p)] = vec4<f32>(filter_of(p, s), dot3(r, s));
}
