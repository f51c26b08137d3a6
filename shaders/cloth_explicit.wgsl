// A whole explicit step of one cloth per workgroup: workgroup w steps
// cloth w of the table `cloths` (common/cloth_bindings.wgsl), with
// barriers between the phases where the multi-dispatch path has separate
// dispatches, calling the same per-item functions: the spring forces
// (spring_forces), the integration (explicit_integrate), every fix-up
// pass until one moves nothing (fixup_jacobi), the step's end
// (finish_step). Twin: the CPU solver's explicit step (cpu::explicit).
// General (adjacency) layout only.
#include "common/cloth_bindings.wgsl"
#include "common/cloth_step.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cloth_explicit(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
) {
    if (!load_cloth(wid.x, lid.x, INTEGRATOR_EXPLICIT)) {
        return;
    }
    let first = params.particle_base;
    let end = first + params.particle_count;
    if (lid.x == 0u) {
        atomicAdd(&status[sw(STATUS_STEP)], 1u);
        reset_fixup();
    }
    for (var s = lid.x; s < params.spring_count; s += SUM_GROUP) {
        spring_force_item(s);
    }
    phase_barrier();
    for (var p = first + lid.x; p < end; p += SUM_GROUP) {
        let x0 = x[p];
        let v0 = v[p];
        let pred = predict(x0, v0, total_force(p, x0, v0, STATE_BUFFERS));
        store_prediction(p, pred[0], pred[1]);
    }
    phase_barrier();
    fixup_passes(lid.x);
    self_collision_phases(lid.x);
    finish_phase(lid.x);
}
