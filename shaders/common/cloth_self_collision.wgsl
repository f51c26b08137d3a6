// Self-collision in a workgroup step (cloth_explicit, cloth_implicit,
// cloth_semi_implicit): the multi-dispatch kernels' items
// (common/self_collision.wgsl) in phases separated by barriers, each
// invocation taking its share of a phase's particles.

#include "common/cloth_bindings.wgsl"
#include "common/self_collision.wgsl"

// The build and every pass, for a cloth with self-collision (nothing
// otherwise). Call from uniform control flow after a phase_barrier; ends
// with one.
fn self_collision_phases(lid: u32) {
    if (broadcast(lid, u32(has_self_collision())) == 0u) {
        return;
    }
    let first = params.particle_base;
    let end = first + params.particle_count;
    for (var p = first + lid; p < end; p += SUM_GROUP) {
        self_collision_count_item(p);
    }
    phase_barrier();
    self_collision_scan_phase(lid);
    phase_barrier();
    for (var p = first + lid; p < end; p += SUM_GROUP) {
        self_collision_scatter_item(p);
    }
    phase_barrier();
    for (var p = first + lid; p < end; p += SUM_GROUP) {
        self_collision_rank_item(p);
    }
    phase_barrier();
    let passes = broadcast(lid, params.self_grid.x);
    for (var k = 0u; k < passes; k++) {
        let last = k + 1u == passes;
        let src = sc_pass_src(k);
        let dst = sc_pass_dst(k, last);
        for (var p = first + lid; p < end; p += SUM_GROUP) {
            if (self_collision_respond_item(p, src, dst, last)) {
                self_collision_moved();
            }
        }
        phase_barrier();
    }
}
