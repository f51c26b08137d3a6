// CG iteration, scalars: α = δ / cᵀq, cᵀq summed from the w of W_Q (one
// workgroup; cg_alpha_scalar, twin: cpu::cg::alpha). A cᵀAc that is not
// positive means c vanished to rounding: CG stops (twin: the CPU's break
// before the update).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cg_alpha(@builtin(local_invocation_id) lid: vec3<u32>) {
    if (cg_stopped(lid.x)) {
        return;
    }
    let running = cg_alpha_scalar(lid.x);
    if (lid.x != 0u) {
        return;
    }
    alpha_slots_next(cg_iteration(), running);
}
