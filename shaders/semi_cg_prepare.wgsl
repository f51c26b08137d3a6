// Semi-implicit step with the scalable filter: set up CG on the constant
// matrix A = M − dt² H (spring blocks a = dt² k, b = 0, uploaded once;
// the linear bending operator's (dt² + dt β) Q, common/bending.wgsl),
// pins as fixed filters, a Jacobi preconditioner (on a grid with the
// coarse levels of common/coarse.wgsl, whose contributions it stores as
// implicit_prepare does), the warm start and the term of δ0 in the w of
// W_RHS. The CPU twin solves the same system exactly with a
// banded Cholesky factor (cpu::filter::BandedFilter).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(WORKGROUP)
fn semi_cg_prepare(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicStore(&status[sw(STATUS_CG_ITERATIONS)], 0u);
        atomicStore(&status[sw(STATUS_CG_STOPPED)], 0u);
    }
    if (p < params.particle_count) {
        var kind = FILTER_FREE;
        if (x[p].w <= 0.0) {
            kind = FILTER_FIXED;
        }
        var diag = v[p].w;
        var levels = levels_start(p, diag, COARSE);
        let begin = spring_adj(p);
        let end = spring_adj(p + 1u);
        let others = spring_adj_others();
        for (var k = begin; k < end; k++) {
            let a = work[si(S_BLOCK, topo(params.spring_adj_entries + k) >> 1u)].w;
            diag += a;
            levels = levels_add(levels, topo(others + k), vec4<f32>(0.0, 0.0, 0.0, a), COARSE);
        }
        if (COARSE) {
            store_levels(p, levels, 3.0 * diag);
        }
        if (has_bending()) {
            diag += bending_scaled_diagonal(p);
        }
        work[wi(W_Z, p)] = vec4<f32>(0.0, 0.0, 0.0, kind);
        work[wi(W_FILTER, p)] = vec4<f32>(0.0);
        work[wi(W_PRE_DIAG, p)] = vec4<f32>(vec3<f32>(1.0 / diag), 0.0);
        work[wi(W_PRE_OFF, p)] = vec4<f32>(0.0);
        let dv = filter_apply(kind, vec3<f32>(0.0), warm_start(p));
        work[wi(W_DV, p)] = vec4<f32>(dv, kind);
        let rhs = work[wi(W_RHS, p)].xyz;
        let sb = filter_apply(kind, vec3<f32>(0.0), rhs);
        work[wi(W_RHS, p)] = vec4<f32>(rhs, dot3(sb, precond_mul(p, sb)));
    }
}
