// Implicit step end: v += Δv, friction at filtered contacts from the
// constraint impulse, x += dt v, collisions (pins: towards their goals),
// the clock, store (implicit_finish_item). Twin:
// cpu::implicit::finish.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/implicit.wgsl"

@compute @workgroup_size(WORKGROUP)
fn implicit_finish(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        record_cg_max();
    }
    if (p >= params.particle_count) {
        return;
    }
    implicit_finish_item(p);
}
