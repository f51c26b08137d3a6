// CG, after each δ: s += S (z₁ + z₂), the coarse corrections of particle
// p's two aggregates (twin: the last loop of cpu::coarse::Coarse::correct).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_prolong(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count || cg_done()) {
        return;
    }
    let z = work[wi(W_COARSE_Z, coarse_of(LEVEL1_SIDE, p))].xyz
        + work[wi(W_COARSE_Z, coarse_of(LEVEL2_SIDE, p))].xyz;
    let s = work[wi(W_S, p)];
    work[wi(W_S, p)] = vec4<f32>(s.xyz + filter_of(p, z), s.w);
}
