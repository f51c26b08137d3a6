// CG, after each δ, off the grid kernels (which add it where cg_apply
// loads s), one invocation per level-1 aggregate: s += S z of its level-2
// aggregate's correction, particle by particle (cg_prolong_item; twin:
// cpu::coarse::Coarse::prolong). s keeps the filter kind in its w.
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
    cg_prolong_item(a);
}
