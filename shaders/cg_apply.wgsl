// CG iteration, part 1: the direction c = s + β c and its product
// q = S A c = S A s + β q (twin: cpu::cg::apply), and cᵀq's term in q's w. On a grid with coarse
// levels the s loaded here is cg_update's plus the level-2 correction
// S z of its level-2 aggregate, added at each stencil point as it is
// loaded (twin: cpu::cg::prolong, then cpu::cg::apply;
// elsewhere cg_prolong adds it before).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"
#include "common/apply_block.wgsl"
#include "generated/grid_block.wgsl"

const APPLY_SEC: u32 = W_S;

// β, loaded once per invocation (a load after a store to `work` is not
// merged with the one before it).
var<private> beta: f32;

@compute @workgroup_size(WORKGROUP)
fn cg_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (cg_done()) {
        return;
    }
    beta = partial(scalar_index(C_BETA));
    if (GRID && COARSE && p < params.grid.w) {
        near_load(grid_block_origin(p), vec2<i32>(i32(BLOCK_ROWS), i32(BLOCK_COLS)));
    }
    // On a grid: one invocation per block of particles.
    if (grid_gather_done(p)) {
        return;
    }
    cg_apply_item(p, beta);
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
    cg_apply_end(p, s, as_p, beta);
}
