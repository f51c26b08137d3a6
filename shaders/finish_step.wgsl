// End of an explicit or semi-implicit step: rebuild the velocity from the
// fixed-up position if the fix-up moved anything, resolve collisions (pins:
// towards their goals), advance the clock, store.
// Twin: cpu::finish_step.
#include "common/bindings.wgsl"
#include "common/step.wgsl"

@compute @workgroup_size(WORKGROUP)
fn finish_step(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count) {
        return;
    }
    finish_particle(p);
}
