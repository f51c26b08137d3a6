// Self-collision's build: each particle into its bucket's run, in any
// order (self_collision_scatter_item); self_collision_rank orders the
// runs. Twin: the scatter of cpu::self_collision::build.
#include "common/bindings.wgsl"
#include "common/self_collision.wgsl"

@compute @workgroup_size(WORKGROUP)
fn self_collision_scatter(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.particle_count) {
        return;
    }
    self_collision_scatter_item(params.particle_base + gid.x);
}
