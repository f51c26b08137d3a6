// CG iteration, part 2: Δv += α c; r −= α q; s = S P r, and the next
// ρ = r·(P r)'s term in s's w. With coarse levels (twin:
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
    if (COARSE) {
        if (gid.x < params.coarse.z) {
            update_aggregate(gid.x);
        }
        return;
    }
    let p = gid.x;
    if (p >= params.particle_count) {
        return;
    }
    let r = update_particle(p);
    let s = precond_mul(p, r);
    work[wi(W_S, p)] = vec4<f32>(filter_of(p, s), dot3(r, s));
}

// Δv and r of particle p after the step α along c (stored); returns r.
fn update_particle(p: u32) -> vec3<f32> {
    var r = work[wi(W_R, p)].xyz;
    if (FIRST) {
        return r;
    }
    let alpha = partials[scalar_index(C_ALPHA)];
    let dv = work[wi(W_DV, p)].xyz + work[wi(W_C, p)].xyz * alpha;
    r -= work[wi(W_Q, p)].xyz * alpha;
    work[wi(W_DV, p)] = vec4<f32>(dv, 0.0);
    work[wi(W_R, p)] = vec4<f32>(r, 0.0);
    return r;
}

// The update of level-1 aggregate `a`'s particles (row-major).
fn update_aggregate(a: u32) {
    // P r and ρ's term of each particle, until the correction is known
    // (in registers: the loops unroll).
    var pr: array<vec4<f32>, LEVEL1_SIDE * LEVEL1_SIDE>;
    var r1 = vec3<f32>(0.0);
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let r = update_particle(p);
            let s = precond_mul(p, r);
            pr[k] = vec4<f32>(s, dot3(r, s));
            r1 += r;
        }
    }
    let z = sym3_mul(coarse_inverse(a), r1);
    work[wi(W_COARSE_Z, a)] = vec4<f32>(r1, dot3(r1, z));
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            work[wi(W_S, p)] = vec4<f32>(filter_of(p, pr[k].xyz) + filter_of(p, z), pr[k].w);
        }
    }
}
