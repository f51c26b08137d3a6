// Semi-implicit step, per particle: v += Δv (free particles), then
// x* = x + dt v as in the explicit scheme; the fix-up and finish_step follow.
#include "common/bindings.wgsl"
#include "common/fixup.wgsl"
#include "common/step.wgsl"

@compute @workgroup_size(WORKGROUP)
fn semi_integrate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        reset_fixup();
        // The scalable filter's CG count (zero with the dense filter).
        atomicMax(&status[sw(STATUS_CG_MAX_ITERATIONS)], atomicLoad(&status[sw(STATUS_CG_ITERATIONS)]));
    }
    if (p >= params.particle_count) {
        return;
    }
    semi_integrate_particle(p);
}
