// Self-collision's build, first pass: each particle's cell and bucket,
// the buckets' counts (self_collision_count_item). Twin: the first loop
// of cpu::self_collision::build.
#include "common/bindings.wgsl"
#include "common/self_collision.wgsl"

@compute @workgroup_size(WORKGROUP)
fn self_collision_count(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.particle_count) {
        return;
    }
    self_collision_count_item(params.particle_base + gid.x);
}
