// The bind group of the workgroup kernels, which step a whole cloth per
// workgroup: common/layout.wgsl with the parameters of every cloth of a
// table in binding 0, and `params` the workgroup's copy of its own cloth's
// (load_cloth), so every common function that reads `params.*` works
// unchanged. Stands in for common/bindings.wgsl (src/gpu/shaders.rs): a
// workgroup kernel includes this file first, and the common files' own
// includes of common/bindings.wgsl are then already satisfied.

#include "common/layout.wgsl"

@group(0) @binding(0) var<storage, read> cloths: array<Params>;

var<workgroup> params: Params;

// The parameters are a cloth table's entry (see common/bindings.wgsl).
const CLOTH_TABLE: bool = true;
var<workgroup> cloth_steps: u32;

// Copies cloth `w`'s parameters into `params` and returns, uniformly over
// the workgroup, whether this kernel steps it: not a removed slot of a
// batch (no particles), and its integrator is `integrator` (a batch with
// several integrators runs each workgroup kernel over the whole table).
fn load_cloth(w: u32, lid: u32, integrator: u32) -> bool {
    if (lid == 0u) {
        params = cloths[w];
        cloth_steps = u32(params.particle_count > 0u && params.integrator == integrator);
    }
    return workgroupUniformLoad(&cloth_steps) != 0u;
}

// The barrier between two phases of a workgroup step: every invocation's
// storage writes are visible to every other's after it. Call from uniform
// control flow.
fn phase_barrier() {
    storageBarrier();
    workgroupBarrier();
}

var<workgroup> shared_word: u32;

// `value` as invocation 0 has it, uniform over the workgroup (for the
// condition of a loop with barriers). Call from uniform control flow.
fn broadcast(lid: u32, value: u32) -> u32 {
    if (lid == 0u) {
        shared_word = value;
    }
    return workgroupUniformLoad(&shared_word);
}
