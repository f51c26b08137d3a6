// CG start: r = S b − S A Δv, c = S P r, and δ = r·c's term in the w of
// W_S (whose xyz the first iteration overwrites).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count) {
        return;
    }
    let q = filter_of(p, apply_a(W_DV, p));
    let r = filter_of(p, work[wi(W_RHS, p)].xyz) - q;
    let c = filter_of(p, precond_mul(p, r));
    work[wi(W_R, p)] = vec4<f32>(r, 0.0);
    work[wi(W_C, p)] = vec4<f32>(c, 0.0);
    work[wi(W_S, p)] = vec4<f32>(0.0, 0.0, 0.0, dot3(r, c));
}
