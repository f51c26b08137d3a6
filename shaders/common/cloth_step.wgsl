// The phases a workgroup step shares between integrators, written once
// for the workgroup kernels (cloth_explicit, cloth_semi_implicit): each
// invocation takes its share of a phase's items, and phase_barrier
// separates the phases.

#include "common/cloth_bindings.wgsl"
#include "common/physics.wgsl"
#include "common/fixup.wgsl"
#include "common/step.wgsl"
#include "common/cloth_self_collision.wgsl"

// The fix-up of a workgroup step: up to params.fixup_iterations Jacobi
// passes, alternating X_PRED and X_ALT, stopping after the first pass
// that moves nothing (as the CPU's `break` and fixup_jacobi's flags do);
// the status words end as after the multi-dispatch passes (passes run,
// the result's section, whether anything moved). Call from uniform
// control flow after a phase_barrier; ends with one.
fn fixup_passes(lid: u32) {
    let passes = broadcast(lid, params.fixup_iterations);
    var src = W_X_PRED;
    var dst = W_X_ALT;
    for (var k = 0u; k < passes; k++) {
        if (lid == 0u) {
            atomicStore(&status[sw(STATUS_FIXUP_FLAG)], 0u);
            atomicStore(&status[sw(STATUS_FIXUP_RESULT)], dst);
            atomicAdd(&status[sw(STATUS_FIXUP_PASSES)], 1u);
        }
        phase_barrier();
        for (var p = params.particle_base + lid; p < params.particle_base + params.particle_count; p += SUM_GROUP) {
            if (fixup_particle(p, src, dst)) {
                fixup_moved(0u);
            }
        }
        phase_barrier();
        if (broadcast(lid, atomicLoad(&status[sw(STATUS_FIXUP_FLAG)])) == 0u) {
            break;
        }
        let t = src;
        src = dst;
        dst = t;
    }
}

// The step's end for every particle of the cloth (finish_step).
fn finish_phase(lid: u32) {
    for (var p = params.particle_base + lid; p < params.particle_base + params.particle_count; p += SUM_GROUP) {
        finish_particle(p);
    }
}
