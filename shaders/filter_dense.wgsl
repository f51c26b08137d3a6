// Semi-implicit dense filter: Δv = W b, one filter position per invocation.
// `dense` holds Wᵀ (so neighbouring invocations read neighbouring words),
// then the filter order. Twin: cpu::filter::DenseFilter::apply.
#include "common/bindings.wgsl"

@compute @workgroup_size(WORKGROUP)
fn filter_dense(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    let n = params.filter_count;
    if (k >= n) {
        return;
    }
    let order = n * n;
    var acc = vec3<f32>(0.0);
    for (var q = 0u; q < n; q++) {
        let particle = bitcast<u32>(dense[order + q]);
        acc += work[wi(W_RHS, particle)].xyz * dense[q * n + k];
    }
    work[wi(W_DV, bitcast<u32>(dense[order + k]))] = vec4<f32>(acc, 0.0);
}
