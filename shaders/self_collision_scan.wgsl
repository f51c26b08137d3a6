// Self-collision's build: the buckets' runs from their counts, by one
// workgroup (self_collision_scan_phase). Twin: the prefix sum of
// cpu::self_collision::build.
#include "common/bindings.wgsl"
#include "common/self_collision.wgsl"

@compute @workgroup_size(SUM_GROUP)
fn self_collision_scan(@builtin(local_invocation_id) lid: vec3<u32>) {
    self_collision_scan_phase(lid.x);
}
