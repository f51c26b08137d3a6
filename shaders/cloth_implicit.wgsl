// A whole implicit step of one cloth per workgroup: workgroup w steps
// cloth w of the table `cloths` (common/cloth_bindings.wgsl), with
// barriers between the phases where the multi-dispatch path has separate
// dispatches, calling the same per-item functions: the spring
// linearisation (implicit_springs), the particles' set-up
// (implicit_prepare), with coarse levels their set-up (coarse_setup),
// CG's start (cg_init; with coarse levels the first update, cg_update,
// first), then CG's iterations — with coarse levels the correction of s
// (cg_prolong_item), cg_apply, cg_update — until CG converges, breaks
// down or has run its maximum, and the step's end (implicit_finish; with
// self-collision its two stages around self_collision_*). Twin: the CPU
// solver's implicit step (cpu::implicit::step). General (adjacency)
// layout only; whether the cloth has coarse levels is read from
// params.coarse, so one pipeline serves cloths with and without them.
//
// The sums are the multi-dispatch kernels' (the CPU mirror's order): a
// workgroup of CG_GROUP lanes, lane l taking particle (or coarse slot) l of
// each reduction block, sums the blocks through the same trees
// (write_block_partials, four blocks to a tree; cg_update_slot and
// write_partials), and the partials' totals through the same tree of
// lanes (sum_partials_tree), which leaves them uniform over the
// workgroup, so every invocation decides the loop alike. The iteration count and CG's stop are in the cloth's
// status words as they are there, so the host reads the same. There are
// no dispatch slots.
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
    // CG's reduction blocks, four to a tree (see write_block_partials):
    // lane l takes particle l of each block, as a cg_* workgroup's lane l
    // does. Uniform over the workgroup: the trees have barriers.
    let quads = broadcast(l, (cg_blocks() + 3u) / 4u);
    for (var g = 0u; g < quads; g++) {
        var d0 = vec4<f32>(0.0);
        var rho = vec4<f32>(0.0);
        for (var c = 0u; c < 4u; c++) {
            let p = (4u * g + c) * CG_GROUP + l;
            if (p < params.particle_count) {
                let t = cg_init_item(first + p, coarse);
                d0[c] = t.x;
                rho[c] = t.y;
            }
        }
        write_block_partials(d0, l, g, P_RES, P_D0);
        if (!coarse) {
            write_block_partials(rho, l, g, P_RES, P_RS);
        }
    }
    phase_barrier();
    if (coarse) {
        coarse_update_phase(l, 0.0, true);
    }
    // Uniform over the workgroup (params is workgroup memory).
    let tol_sq = bitcast<f32>(broadcast(l, bitcast<u32>(params.cg_tolerance_sq)));
    var delta0 = 0.0;
    var delta_prev = 0.0;
    for (var k = 0u; k < max_iterations; k++) {
        let sums = cg_residual_sums(l, k == 0u, coarse);
        if (k == 0u) {
            delta0 = sums.z;
        }
        if (!(sums.x > tol_sq * delta0)) {
            cg_stop(l);
            break;
        }
        let beta = select(sums.y / delta_prev, 0.0, k == 0u);
        if (coarse) {
            for (var a = l; a < level1; a += SUM_GROUP) {
                cg_prolong_item(a);
            }
            phase_barrier();
        }
        for (var g = 0u; g < quads; g++) {
            var cq = vec4<f32>(0.0);
            for (var c = 0u; c < 4u; c++) {
                let p = (4u * g + c) * CG_GROUP + l;
                if (p < params.particle_count) {
                    cq[c] = cg_apply_item(first + p, beta);
                }
            }
            write_block_partials(cq, l, g, P_CQ, 0u);
        }
        phase_barrier();
        let cq = sum_partials_tree(P_CQ, vec4<u32>(cg_blocks(), 0u, 0u, 0u), l).x;
        if (!(finite1(cq) && cq > 0.0)) {
            cg_stop(l);
            break;
        }
        let alpha = sums.y / cq;
        if (coarse) {
            coarse_update_phase(l, alpha, false);
        } else {
            for (var g = 0u; g < quads; g++) {
                var rho = vec4<f32>(0.0);
                for (var c = 0u; c < 4u; c++) {
                    let p = (4u * g + c) * CG_GROUP + l;
                    if (p < params.particle_count) {
                        rho[c] = cg_update_item(first + p, alpha, false);
                    }
                }
                write_block_partials(rho, l, g, P_RES, P_RS);
            }
            phase_barrier();
        }
        delta_prev = sums.y;
        if (l == 0u) {
            atomicStore(&status[sw(STATUS_CG_ITERATIONS)], k + 1u);
        }
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

// CG stops (converged or broke down): the status word the host reads.
fn cg_stop(lid: u32) {
    if (lid == 0u) {
        atomicStore(&status[sw(STATUS_CG_STOPPED)], 1u);
    }
}

// The per-slot cg_update (twin: cpu::cg::update's coarse part), a
// workgroup's worth of slots at a time: lane l takes slot l of each run
// of CG_GROUP slots, as cg_update's workgroups do, the same function
// (cg_update_slot) and the same partial sums. Call from uniform control
// flow.
fn coarse_update_phase(l: u32, alpha: f32, first: bool) {
    let runs = broadcast(l, coarse_slot_partials());
    var mask = vec4<bool>(false);
    mask[P_RS] = true;
    mask[P_DC] = true;
    for (var g = 0u; g < runs; g++) {
        let terms = cg_update_slot(g * CG_GROUP + l, l, alpha, first, true);
        var res = vec4<f32>(0.0);
        res[P_RS] = terms.x;
        res[P_DC] = terms.y;
        write_partials(res, l, g, P_RES, mask, true);
    }
    phase_barrier();
}
