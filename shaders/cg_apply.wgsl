// CG iteration, part 1 (twin: cpu::cg::apply): every workgroup sums ρ
// and δ (and in the first iteration δ0) from the partials the last
// kernel left (cg_residual_sums: the same bits in each), and CG stops once
// ρ ≤ tol² δ0; else β = δ / δ_prev, the direction c = s + β c and its
// product q = S A c = S A s + β q, and cᵀq's term in q's w, summed per
// workgroup into partials for cg_update. With coarse levels the s loaded
// at each point is cg_update's plus the level-2 correction S z of its
// level-2 aggregate (on a grid near_correction, else cg_source). The
// first invocation keeps the scalars and enables the iteration's
// cg_update (apply_slots).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"
#include "common/apply_block.wgsl"
#include "generated/grid_block.wgsl"

const APPLY_SEC: u32 = W_S;

var<private> beta: f32;
// cᵀq's term of this invocation's particle.
var<private> term: f32;

@compute @workgroup_size(CG_GROUP)
fn cg_apply(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let p = gid.x;
    let k = atomicLoad(&status[sw(STATUS_CG_ITERATIONS)]);
    let first = k == 0u;
    let sums = cg_residual_sums(lid.x, first, COARSE);
    let delta0 = select(partial(scalar_index(C_DELTA0)), sums.z, first);
    let running = sums.x > params.cg_tolerance_sq * delta0;
    beta = select(sums.y / partial(scalar_index(C_DELTA_PREV)), 0.0, first);
    term = 0.0;
    if (running) {
        if (GRID && COARSE && p < params.particle_count) {
            near_load(grid_block_origin(p), vec2<i32>(1, 1));
        }
        // On a grid the gather calls apply_end.
        if (!grid_gather_done(p)) {
            term = cg_apply_item(p, beta);
        }
    }
    let x_only = vec4<bool>(true, false, false, false);
    write_partials(vec4<f32>(term, 0.0, 0.0, 0.0), lid.x, wid.x, P_CQ, x_only, running);
    if (p == 0u) {
        apply_slots(k, running, delta0, sums.y, beta);
    }
}

// s at a stencil point from what cg_update stored there (s and the
// filter kind).
fn apply_value(pt: GridPoint, stored: vec4<f32>) -> vec3<f32> {
    if (!(GRID && COARSE)) {
        return stored.xyz;
    }
    return stored.xyz + filter_with(stored.w, pt.index, near_correction(pt.rc));
}

// c = s + β c and q = S (A s) + β q for particle p, whose s (with its
// filter kind in w) is `s` and (A s)_p, unfiltered, `as_p` (the grid
// gather's hook).
fn apply_end(p: u32, s: vec4<f32>, as_p: vec3<f32>) {
    term = cg_apply_end(p, s, as_p, beta);
}
