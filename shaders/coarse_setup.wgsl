// Implicit step, per aggregate of the coarse levels: D, summed from its
// particles' contributions (left by implicit_prepare), and its inverse
// weighted by θ = 1 − 3 Σm / Σ tr(A_ii), or zero where D is not
// invertible (coarse_setup_item; twin: cpu::coarse::Coarse::setup).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(WORKGROUP)
fn coarse_setup(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if (k >= params.coarse.z + params.coarse.w) {
        return;
    }
    coarse_setup_item(k);
}
