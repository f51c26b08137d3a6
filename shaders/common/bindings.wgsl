// The bind group of the multi-dispatch kernels: common/layout.wgsl with
// the parameters as a uniform block. Included by each kernel file through
// `#include "common/bindings.wgsl"` (src/gpu/shaders.rs); a workgroup
// kernel includes common/cloth_bindings.wgsl instead, which stands in for
// this file.

#include "common/layout.wgsl"

@group(0) @binding(0) var<uniform> params: Params;

// The parameters are one cloth's uniform block, not a cloth table's entry.
const CLOTH_TABLE: bool = false;
