// CG scalars, once per solve (one workgroup): δ0, ρ and δ, and whether CG
// is done before its first iteration (cg_start_scalars; twin:
// cpu::cg::start); the indirect dispatch arguments of the first
// iteration.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cg_start(@builtin(local_invocation_id) lid: vec3<u32>) {
    let running = cg_start_scalars(lid.x, COARSE);
    if (lid.x != 0u) {
        return;
    }
    start_slots(running);
}
