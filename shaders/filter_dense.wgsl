// Semi-implicit dense filter: Δv = W b, one filter position per invocation.
// `dense` holds Wᵀ (so neighbouring invocations read neighbouring words),
// then the filter order. Twin: cpu::filter::DenseFilter::apply.
#include "common/bindings.wgsl"
#include "common/step.wgsl"

@compute @workgroup_size(WORKGROUP)
fn filter_dense(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    if (k >= params.filter_count) {
        return;
    }
    filter_dense_row(k);
}
