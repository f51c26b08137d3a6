// CG iteration, part 2: Δv += α c; r −= α q; s = S P r, with the next
// ρ = r·(P r)'s term in r's w and the particle's filter kind in s's w
// (for cg_apply, which filters its neighbours' s). With coarse levels (twin:
// cpu::coarse::Coarse::level1), one invocation per level-1 aggregate,
// which also adds its correction S D⁻¹Πᵀr to s and leaves Πᵀr and its
// term of δ in W_COARSE_Z for cg_beta. The FIRST variant (after cg_init,
// dispatched directly) only preconditions the initial residual.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

override FIRST: bool = false;

@compute @workgroup_size(WORKGROUP)
fn cg_update(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (cg_done()) {
        return;
    }
    // α once per invocation (a load after a store to `work` is not
    // merged with the one before it).
    let alpha = partials[scalar_index(C_ALPHA)];
    if (COARSE) {
        if (gid.x < params.coarse.z) {
            update_aggregate(gid.x, alpha);
        }
        return;
    }
    let p = gid.x;
    if (p >= params.particle_count) {
        return;
    }
    let rk = update_particle(p, alpha);
    let r = rk.xyz;
    let s = precond_mul(p, r);
    work[wi(W_R, p)] = vec4<f32>(r, dot3(r, s));
    work[wi(W_S, p)] = vec4<f32>(filter_with(rk.w, p, s), rk.w);
}

// Δv of particle p after the step `alpha` along c (stored) and r after
// it (returned, with the particle's filter kind in w: the caller stores r
// with its term of ρ).
fn update_particle(p: u32, alpha: f32) -> vec4<f32> {
    var r = work[wi(W_R, p)].xyz;
    if (FIRST) {
        return vec4<f32>(r, filter_kind(p));
    }
    let dv = work[wi(W_DV, p)];
    let dv_new = dv.xyz + work[wi(W_C, p)].xyz * alpha;
    r -= work[wi(W_Q, p)].xyz * alpha;
    work[wi(W_DV, p)] = vec4<f32>(dv_new, dv.w);
    return vec4<f32>(r, dv.w);
}

// The update of level-1 aggregate `a`'s particles (row-major).
fn update_aggregate(a: u32, alpha: f32) {
    // P r and the filter kind of each particle, until the correction is
    // known (in registers: the loops unroll).
    var pr: array<vec4<f32>, LEVEL1_SIDE * LEVEL1_SIDE>;
    var r1 = vec3<f32>(0.0);
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let rk = update_particle(p, alpha);
            let r = rk.xyz;
            let s = precond_mul(p, r);
            work[wi(W_R, p)] = vec4<f32>(r, dot3(r, s));
            pr[k] = vec4<f32>(s, rk.w);
            r1 += r;
        }
    }
    let z = sym3_mul(coarse_inverse(a), r1);
    work[wi(W_COARSE_Z, a)] = vec4<f32>(r1, dot3(r1, z));
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let kind = pr[k].w;
            let s = filter_with(kind, p, pr[k].xyz) + filter_with(kind, p, z);
            work[wi(W_S, p)] = vec4<f32>(s, kind);
        }
    }
}
