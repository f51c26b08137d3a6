// Implicit step, per spring: the linearisation at the start of the step
// (general kernels only: on a grid each kernel linearises the springs it
// uses from the particles' state; implicit_springs_item). Twin:
// cpu::implicit::springs.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/implicit.wgsl"

@compute @workgroup_size(WORKGROUP)
fn implicit_springs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let s = gid.x;
    if (s >= params.spring_count) {
        return;
    }
    implicit_springs_item(s);
}
