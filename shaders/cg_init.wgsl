// CG start: r = S b − S A Δv, s = S P r with δ = r·s's term in its w, and
// a zero previous direction and product (the first iteration has β = 0).
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
    apply_end(p, work[wi(W_DV, p)].xyz, apply_a(W_DV, p));
}

// The set-up of particle p from (A Δv)_p, unfiltered, `adv`.
fn apply_end(p: u32, dv: vec3<f32>, adv: vec3<f32>) {
    let q = filter_of(p, adv);
    let r = filter_of(p, work[wi(W_RHS, p)].xyz) - q;
    let s = filter_of(p, precond_mul(p, r));
    work[wi(W_R, p)] = vec4<f32>(r, 0.0);
    work[wi(W_S, p)] = vec4<f32>(s, dot3(r, s));
    work[wi(W_C, p)] = vec4<f32>(0.0);
    work[wi(W_Q, p)] = vec4<f32>(0.0);
}
