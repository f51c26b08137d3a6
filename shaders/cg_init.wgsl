// CG start: r = S b − S A Δv, c = S P r, partial sums of δ = r·c.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_init(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    let p = gid.x;
    var delta = 0.0;
    if (p < params.particle_count) {
        let q = filter_of(p, apply_a(W_DV, p));
        let r = filter_of(p, work[wi(W_RHS, p)].xyz) - q;
        let c = filter_of(p, precond_mul(p, r));
        work[wi(W_R, p)] = vec4<f32>(r, 0.0);
        work[wi(W_C, p)] = vec4<f32>(c, 0.0);
        delta = dot3(r, c);
    }
    reduce_to_partial(delta, lid.x, wg.x, P_RS);
}
