// A whole semi-implicit step with the dense filter of one cloth per
// workgroup: workgroup w steps cloth w of the table `cloths`
// (common/cloth_bindings.wgsl), with barriers between the phases where
// the multi-dispatch path has separate dispatches, calling the same
// per-item functions: the spring forces (spring_forces), the right-hand
// side (semi_rhs), the dense filter (filter_dense), for a cloth without
// pins the global torque compensation (torque_centre, torque_moments,
// torque_apply: their sums in the CPU mirror's order), the integration
// (semi_integrate), every fix-up pass until one moves nothing
// (fixup_jacobi), self-collision (self_collision_*), the step's end
// (finish_step). Twin: the CPU solver's
// semi-implicit step with the dense filter (cpu::semi_implicit). General
// (adjacency) layout only; a cloth whose filter is solved by CG takes the
// multi-dispatch path.
#include "common/cloth_bindings.wgsl"
#include "common/cloth_step.wgsl"
#include "common/semi.wgsl"
#include "common/torque.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn cloth_semi_implicit(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
) {
    if (!load_cloth(wid.x, lid.x, INTEGRATOR_SEMI_IMPLICIT)) {
        return;
    }
    let first = params.particle_base;
    let end = first + params.particle_count;
    if (lid.x == 0u) {
        atomicAdd(&status[sw(STATUS_STEP)], 1u);
    }
    for (var s = lid.x; s < params.spring_count; s += SUM_GROUP) {
        spring_force_item(s);
    }
    phase_barrier();
    for (var p = first + lid.x; p < end; p += SUM_GROUP) {
        semi_rhs_particle(p, true);
    }
    phase_barrier();
    for (var k = lid.x; k < params.filter_count; k += SUM_GROUP) {
        filter_dense_row(k);
    }
    phase_barrier();
    if (broadcast(lid.x, params.torque_compensation & TORQUE_GLOBAL) != 0u) {
        remove_rigid_rotation(lid.x);
    }
    if (lid.x == 0u) {
        reset_fixup();
        // The scalable filter's CG count in the multi-dispatch path (zero
        // with the dense filter), kept for the same status words.
        atomicMax(&status[sw(STATUS_CG_MAX_ITERATIONS)], atomicLoad(&status[sw(STATUS_CG_ITERATIONS)]));
    }
    for (var p = first + lid.x; p < end; p += SUM_GROUP) {
        semi_integrate_particle(p);
    }
    phase_barrier();
    fixup_passes(lid.x);
    self_collision_phases(lid.x);
    finish_phase(lid.x);
}

// The global torque compensation (torque_centre, torque_moments,
// torque_apply) inside the workgroup: invocation b sums block b's terms
// in particle order into the partials, as reduce_to_partial's invocation
// 0 does, then the block sums are added in sequence (sum_partials), so
// every sum has the CPU mirror's order. Each term passes through unseen1:
// several are products, which the compiler would otherwise fuse into the
// running sum (the multi-dispatch kernels store them to workgroup memory
// first). Ends with a phase_barrier.
fn remove_rigid_rotation(lid: u32) {
    for (var b = lid; b < params.partial_count; b += SUM_GROUP) {
        var sums = array<f32, T_CENTRE_SUMS>();
        for (var p = reduction_first(b); p < reduction_end(b); p++) {
            let t = centre_terms(p);
            for (var k = 0u; k < T_CENTRE_SUMS; k++) {
                sums[k] += unseen1(t[k]);
            }
        }
        for (var k = 0u; k < T_CENTRE_SUMS; k++) {
            set_partial(pi(torque_slot(T_MASS + k), b), sums[k]);
        }
    }
    phase_barrier();
    let centre = centre_of_mass(lid);
    for (var b = lid; b < params.partial_count; b += SUM_GROUP) {
        var sums = array<f32, T_MOMENT_SUMS>();
        for (var p = reduction_first(b); p < reduction_end(b); p++) {
            let t = moment_terms(p, centre);
            for (var k = 0u; k < T_MOMENT_SUMS; k++) {
                sums[k] += unseen1(t[k]);
            }
        }
        for (var k = 0u; k < T_MOMENT_SUMS; k++) {
            set_partial(pi(torque_slot(T_EXCESS + k), b), sums[k]);
        }
    }
    phase_barrier();
    let omega = torque_omega(lid);
    if (omega.w != 0.0) {
        for (var p = params.particle_base + lid; p < params.particle_base + params.particle_count; p += SUM_GROUP) {
            remove_rotation(p, omega.xyz, centre);
        }
    }
    phase_barrier();
}

// The first particle of reduction block b, and one past its last.
fn reduction_first(b: u32) -> u32 {
    return params.particle_base + b * WORKGROUP;
}

fn reduction_end(b: u32) -> u32 {
    return params.particle_base + min((b + 1u) * WORKGROUP, params.particle_count);
}
