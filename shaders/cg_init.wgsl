// CG start, once per solve: r = S b − S A Δv with ρ = r·s's term in its
// w, s = S P r with the particle's filter kind in its w (see cg_update;
// with coarse levels cg_update with FIRST computes s and ρ's terms), and a
// zero previous direction and product (the first iteration has β = 0):
// cg_init_end (twin: cpu::cg::init). Each workgroup leaves its partial
// sums of δ0's and ρ's terms for cg_apply; the first invocation clears
// the slots the last solve left enabled and enables the first cg_apply
// (start_slots).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/apply_block.wgsl"
#include "generated/grid_block.wgsl"

const APPLY_SEC: u32 = W_DV;

// The terms of δ0 and ρ of this invocation's particle.
var<private> terms: vec2<f32>;

@compute @workgroup_size(CG_GROUP)
fn cg_init(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let p = gid.x;
    terms = vec2<f32>(0.0);
    // On a grid the gather calls apply_end.
    if (!grid_gather_done(p)) {
        terms = cg_init_item(p, COARSE);
    }
    var res = vec4<f32>(0.0);
    res[P_D0] = terms.x;
    res[P_RS] = terms.y;
    var mask = vec4<bool>(false);
    mask[P_D0] = true;
    mask[P_RS] = !COARSE;
    write_partials(res, lid.x, wid.x, P_RES, mask, true);
    if (p == 0u) {
        start_slots();
    }
}

// The vector the product takes at a stencil point: Δv as stored.
fn apply_value(pt: GridPoint, stored: vec4<f32>) -> vec3<f32> {
    return stored.xyz;
}

// The set-up of particle p, whose Δv (with its filter kind in w) is `dv`,
// from (A Δv)_p, unfiltered, `adv` (the grid gather's hook).
fn apply_end(p: u32, dv: vec4<f32>, adv: vec3<f32>) {
    terms = cg_init_end(p, dv, adv, COARSE);
}
