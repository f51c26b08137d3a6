// CG iteration, part 2 (twin: cpu::cg::update): every workgroup sums cᵀq
// from cg_apply's partials (the same bits in each), α = δ / cᵀq, and CG
// stops if cᵀq is not positive; else Δv += α c, r −= α q, s = S P r with
// the particle's filter kind in its w and ρ's term in r's w
// (cg_update_item), summed per workgroup into partials for the next
// cg_apply. With coarse levels (twin: cpu::coarse::Coarse::level1, level2,
// partials) one invocation per slot of the level-2-major order of the
// level-1 aggregates (cg_update_slot), which also adds level 1's
// correction to s, and each workgroup sums its level-2 aggregates'
// residuals for their corrections and sums δ's coarse terms. The first
// invocation keeps α, counts the iteration and enables the next
// cg_apply (update_slots). The FIRST variant (after cg_init, coarse
// levels only, dispatched directly) only preconditions the initial
// residual.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

override FIRST: bool = false;

@compute @workgroup_size(CG_GROUP)
fn cg_update(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    var alpha = 0.0;
    var running = true;
    let delta = partial(scalar_index(C_DELTA));
    if (!FIRST) {
        let cq = sum_partials_tree(P_CQ, vec4<u32>(cg_blocks(), 0u, 0u, 0u), lid.x).x;
        alpha = delta / cq;
        running = finite1(cq) && cq > 0.0;
    }
    var terms = vec2<f32>(0.0);
    if (COARSE) {
        terms = cg_update_slot(gid.x, lid.x, alpha, FIRST, running);
    } else if (running && gid.x < params.particle_count) {
        terms.x = cg_update_item(gid.x, alpha, FIRST);
    }
    var res = vec4<f32>(0.0);
    res[P_RS] = terms.x;
    res[P_DC] = terms.y;
    var mask = vec4<bool>(false);
    mask[P_RS] = true;
    mask[P_DC] = COARSE;
    write_partials(res, lid.x, wid.x, P_RES, mask, running);
    if (!FIRST && gid.x == 0u) {
        update_slots(atomicLoad(&status[sw(STATUS_UPDATE_SLOT)]), running, alpha, delta);
    }
}
