// CG start: r = S b − S A Δv with ρ = r·s's term in its w, s = S P r
// with the particle's filter kind in its w (see cg_update; with coarse
// levels cg_update with FIRST computes s and ρ's terms), and a zero previous
// direction and product (the first iteration has β = 0).
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
    apply_end(p, work[wi(W_DV, p)], apply_a(W_DV, p));
}

// The vector the product takes at a stencil point: Δv as stored.
fn apply_value(pt: GridPoint, stored: vec4<f32>) -> vec3<f32> {
    return stored.xyz;
}

// The set-up of particle p, whose Δv (with its filter kind in w) is `dv`,
// from (A Δv)_p, unfiltered, `adv`.
fn apply_end(p: u32, dv: vec4<f32>, adv: vec3<f32>) {
    let kind = dv.w;
    let q = filter_with(kind, p, adv);
    let r = filter_with(kind, p, work[wi(W_RHS, p)].xyz) - q;
    if (COARSE) {
        // cg_update with FIRST preconditions r with the coarse levels.
        work[wi(W_R, p)] = vec4<f32>(r, 0.0);
    } else {
        let s = filter_with(kind, p, precond_mul(p, r));
        work[wi(W_R, p)] = vec4<f32>(r, dot3(r, s));
        work[wi(W_S, p)] = vec4<f32>(s, kind);
    }
    work[wi(W_C, p)] = vec4<f32>(0.0);
    work[wi(W_Q, p)] = vec4<f32>(0.0);
}
