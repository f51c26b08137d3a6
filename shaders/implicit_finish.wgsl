// Implicit step end: v += Δv, friction at filtered contacts from the
// constraint impulse, x += dt v, collisions (pins: towards their goals),
// the clock, store (implicit_finish_item). With self-collision, in two
// stages around its passes: the prediction stored
// (implicit_store_prediction), then v += Δx / dt and the rest
// (implicit_project_item). Twin: cpu::implicit::finish.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/implicit.wgsl"

// 0: the whole end; 1: the prediction before self-collision; 2: the end
// after it.
override STAGE: u32 = 0u;

@compute @workgroup_size(WORKGROUP)
fn implicit_finish(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u && STAGE != 2u) {
        record_cg_max();
    }
    if (p >= params.particle_count) {
        return;
    }
    switch STAGE {
        case 1u: {
            implicit_store_prediction(p);
        }
        case 2u: {
            implicit_project_item(p);
        }
        default: {
            implicit_finish_item(p);
        }
    }
}
