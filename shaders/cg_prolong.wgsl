// CG, after each δ, off the grid kernels (which add it where cg_apply
// loads s), one invocation per level-1 aggregate: s += S z of its level-2
// aggregate's correction, particle by particle (twin: the last loop of
// cpu::coarse::Coarse::level2). s keeps the filter kind in its w.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_prolong(@builtin(global_invocation_id) gid: vec3<u32>) {
    let a = gid.x;
    if (a >= params.coarse.z || cg_done()) {
        return;
    }
    let z = work[wi(W_COARSE_Z, coarse_of(LEVEL2_SIDE, level1_particle(a, 0u)))].xyz;
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let s = work[wi(W_S, p)];
            work[wi(W_S, p)] = vec4<f32>(s.xyz + filter_with(s.w, p, z), s.w);
        }
    }
}
