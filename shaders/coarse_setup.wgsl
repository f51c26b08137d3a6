// Implicit step, per aggregate of the coarse levels: D, summed from its
// particles' contributions (left by implicit_prepare), and its inverse
// weighted by θ = 1 − 3 Σm / Σ tr(A_ii), or zero where D is not
// invertible (twin: cpu::coarse::Coarse::setup).
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

@compute @workgroup_size(WORKGROUP)
fn coarse_setup(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    let n1 = params.coarse.z;
    if (k >= n1 + params.coarse.w) {
        return;
    }
    var side = LEVEL1_SIDE;
    var index = k;
    var sec_d = W_LEVEL1_D;
    var sec_o = W_LEVEL1_O;
    if (k >= n1) {
        side = LEVEL2_SIDE;
        index = k - n1;
        sec_d = W_LEVEL2_D;
        sec_o = W_LEVEL2_O;
    }
    let nx = params.coarse.x;
    let across = coarse_across(side);
    let row0 = (index / across) * side;
    let col0 = (index % across) * side;
    var d = vec3<f32>(0.0);
    var o = vec3<f32>(0.0);
    var mass = 0.0;
    var trace = 0.0;
    for (var row = row0; row < min(row0 + side, params.coarse.y); row++) {
        for (var col = col0; col < min(col0 + side, nx); col++) {
            let p = row * nx + col;
            d += work[wi(sec_d, p)].xyz;
            o += work[wi(sec_o, p)].xyz;
            mass += v[p].w;
            trace += work[wi(W_LEVEL1_O, p)].w;
        }
    }
    let inv = sym3_inverse(Sym3(d, o));
    var theta = 0.0;
    if (trace > 0.0) {
        theta = 1.0 - 3.0 * mass / trace;
    }
    var m = Sym3(vec3<f32>(0.0), vec3<f32>(0.0));
    if (inv.ok) {
        m = Sym3(inv.m.d * theta, inv.m.o * theta);
    }
    work[wi(W_COARSE_INV_D, k)] = vec4<f32>(m.d, 0.0);
    work[wi(W_COARSE_INV_O, k)] = vec4<f32>(m.o, 0.0);
}
