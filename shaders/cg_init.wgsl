// CG start: r = S b − S A Δv with ρ = r·s's term in its w, s = S P r
// with the particle's filter kind in its w (see cg_update; with coarse
// levels cg_update with FIRST computes s and ρ's terms), and a zero previous
// direction and product (the first iteration has β = 0): cg_init_end (twin:
// cpu::cg::init).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/apply_block.wgsl"
#include "generated/grid_block.wgsl"

const APPLY_SEC: u32 = W_DV;

@compute @workgroup_size(WORKGROUP)
fn cg_init(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    // On a grid: one invocation per block of particles.
    if (grid_gather_done(p)) {
        return;
    }
    cg_init_item(p, COARSE);
}

// The vector the product takes at a stencil point: Δv as stored.
fn apply_value(pt: GridPoint, stored: vec4<f32>) -> vec3<f32> {
    return stored.xyz;
}

// The set-up of particle p, whose Δv (with its filter kind in w) is `dv`,
// from (A Δv)_p, unfiltered, `adv` (the grid gather's hook).
fn apply_end(p: u32, dv: vec4<f32>, adv: vec3<f32>) {
    cg_init_end(p, dv, adv, COARSE);
}
