// Self-collision's build, last pass: each bucket's run in index order
// (self_collision_rank_item). Twin: the scatter of
// cpu::self_collision::build.
#include "common/bindings.wgsl"
#include "common/self_collision.wgsl"

@compute @workgroup_size(WORKGROUP)
fn self_collision_rank(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.particle_count) {
        return;
    }
    self_collision_rank_item(params.particle_base + gid.x);
}
