// CG iteration, part 3: β = δ_new / δ; c = S (s + β c); count the iteration.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

override RS: u32 = 1u;
override RS_NEXT: u32 = 2u;

@compute @workgroup_size(WORKGROUP)
fn cg_direction(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
) {
    if (cg_stopped(lid.x, RS)) {
        return;
    }
    if (lid.x == 0u) {
        shared_value = sum_partials(RS_NEXT) / sum_partials(RS);
    }
    let beta = workgroupUniformLoad(&shared_value);
    let p = gid.x;
    if (p == 0u) {
        atomicAdd(&status[STATUS_CG_ITERATIONS], 1u);
    }
    if (p < params.particle_count) {
        let c = filter_of(p, work[wi(W_S, p)].xyz + work[wi(W_C, p)].xyz * beta);
        work[wi(W_C, p)] = vec4<f32>(c, 0.0);
    }
}
