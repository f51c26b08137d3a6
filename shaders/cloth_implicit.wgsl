// A whole implicit step of one cloth per workgroup: workgroup w steps
// cloth w of the table `cloths` (common/cloth_bindings.wgsl), with
// barriers between the phases where the multi-dispatch path has separate
// dispatches, calling the same per-item functions: the spring
// linearisation (implicit_springs), the particles' set-up
// (implicit_prepare), with coarse levels their set-up (coarse_setup) and
// the first update (cg_update, first), CG's start (cg_init, cg_start),
// then CG's iterations — cg_apply, cg_alpha, cg_update, cg_beta and with
// coarse levels cg_prolong — until CG converges, breaks down or has run
// its maximum, and the step's end (implicit_finish; with
// self-collision its two stages around self_collision_*). Twin: the CPU
// solver's implicit step (cpu::implicit::step). General (adjacency)
// layout only; whether the cloth has coarse levels is read from
// params.coarse, so one pipeline serves cloths with and without them.
//
// The sums are the multi-dispatch scalar kernels' (sum_w: the CPU
// mirror's order), and the iteration count and CG's stop are in the
// cloth's status words as they are there, so the host reads the same.
// There are no dispatch slots: the loop ends when invocation 0 finds CG
// stopped, which it shares with the workgroup (broadcast).
#include "common/cloth_bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"
#include "common/implicit.wgsl"
#include "common/cloth_self_collision.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cloth_implicit(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
) {
    if (!load_cloth(wid.x, lid.x, INTEGRATOR_IMPLICIT)) {
        return;
    }
    let l = lid.x;
    let first = params.particle_base;
    let end = first + params.particle_count;
    // Uniform over the workgroup: barriers depend on them.
    let coarse = broadcast(l, params.coarse.z) != 0u;
    let max_iterations = broadcast(l, params.cg_max_iterations);
    let level1 = params.coarse.z;
    if (l == 0u) {
        implicit_step_start();
    }
    for (var s = l; s < params.spring_count; s += SUM_GROUP) {
        implicit_springs_item(s);
    }
    phase_barrier();
    for (var p = first + l; p < end; p += SUM_GROUP) {
        implicit_prepare_item(p, coarse);
    }
    phase_barrier();
    if (coarse) {
        for (var k = l; k < level1 + params.coarse.w; k += SUM_GROUP) {
            coarse_setup_item(k);
        }
        phase_barrier();
    }
    for (var p = first + l; p < end; p += SUM_GROUP) {
        cg_init_item(p, coarse);
    }
    phase_barrier();
    if (coarse) {
        for (var a = l; a < level1; a += SUM_GROUP) {
            cg_update_aggregate(a, 0.0, true);
        }
        phase_barrier();
    }
    var running = cg_share(l, cg_start_scalars(l, coarse));
    for (var k = 0u; k < max_iterations && running; k++) {
        if (coarse) {
            for (var a = l; a < level1; a += SUM_GROUP) {
                cg_prolong_item(a);
            }
            phase_barrier();
        }
        let beta = partial(scalar_index(C_BETA));
        for (var p = first + l; p < end; p += SUM_GROUP) {
            cg_apply_item(p, beta);
        }
        phase_barrier();
        if (!cg_share(l, cg_alpha_scalar(l))) {
            break;
        }
        let alpha = partial(scalar_index(C_ALPHA));
        if (coarse) {
            for (var a = l; a < level1; a += SUM_GROUP) {
                cg_update_aggregate(a, alpha, false);
            }
        } else {
            for (var p = first + l; p < end; p += SUM_GROUP) {
                cg_update_item(p, alpha, false);
            }
        }
        phase_barrier();
        running = cg_share(l, cg_beta_scalars(l, coarse).running);
    }
    if (l == 0u) {
        record_cg_max();
    }
    if (broadcast(l, u32(has_self_collision())) != 0u) {
        for (var p = first + l; p < end; p += SUM_GROUP) {
            implicit_store_prediction(p);
        }
        phase_barrier();
        self_collision_phases(l);
        for (var p = first + l; p < end; p += SUM_GROUP) {
            implicit_project_item(p);
        }
    } else {
        for (var p = first + l; p < end; p += SUM_GROUP) {
            implicit_finish_item(p);
        }
    }
}

// Invocation 0's `running` (from a scalar function, which stored its
// scalars in `partials`), uniform over the workgroup, after a barrier
// that makes those scalars visible to every invocation.
fn cg_share(lid: u32, running: bool) -> bool {
    phase_barrier();
    return broadcast(lid, u32(running)) != 0u;
}
