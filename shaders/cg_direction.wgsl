// CG iteration, part 3: c = S (s + β c).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_direction(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count || cg_done()) {
        return;
    }
    let beta = partials[scalar_index(C_BETA)];
    let c = filter_of(p, work[wi(W_S, p)].xyz + work[wi(W_C, p)].xyz * beta);
    work[wi(W_C, p)] = vec4<f32>(c, 0.0);
}
