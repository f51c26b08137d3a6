// Per spring: the force on end i (twin:
// cpu::forces::spring_forces), for the particles to gather.
#include "common/bindings.wgsl"
#include "common/step.wgsl"

@compute @workgroup_size(WORKGROUP)
fn spring_forces(@builtin(global_invocation_id) gid: vec3<u32>) {
    let s = gid.x;
    if (s >= params.spring_count) {
        return;
    }
    spring_force_item(s);
}
