// CG iteration, part 1: the direction c = s + β c and its product
// q = S A c = S A s + β q (twin: the folded direction update of
// cpu::implicit::step), and cᵀq's term in q's w.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/apply_block.wgsl"
#include "generated/grid_block.wgsl"

const APPLY_SEC: u32 = W_S;

@compute @workgroup_size(WORKGROUP)
fn cg_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (cg_done()) {
        return;
    }
    // On a grid: one invocation per block of particles.
    if (grid_gather_done(p)) {
        return;
    }
    apply_end(p, work[wi(W_S, p)].xyz, apply_a(W_S, p));
}

// c = s + β c and q = S (A s) + β q for particle p, whose s is `s` and
// (A s)_p, unfiltered, `as_p`.
fn apply_end(p: u32, s: vec3<f32>, as_p: vec3<f32>) {
    let beta = partials[scalar_index(C_BETA)];
    let t = filter_of(p, as_p);
    let c = s + work[wi(W_C, p)].xyz * beta;
    let q = t + work[wi(W_Q, p)].xyz * beta;
    work[wi(W_C, p)] = vec4<f32>(c, 0.0);
    work[wi(W_Q, p)] = vec4<f32>(q, dot3(c, q));
}
