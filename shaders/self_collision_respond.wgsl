// One Jacobi pass of self-collision's response: each particle's contacts
// from the pass's section, its new position into the next
// (self_collision_respond_item); the last pass caps the step's
// displacement and writes where the step's end reads. Twin: one pass of
// cpu::self_collision::apply (respond, then the cap).
#include "common/bindings.wgsl"
#include "common/self_collision.wgsl"

// The pass: 0 the first; which sections it uses is sc_pass_src/dst's.
override PASS: u32 = 0u;
override LAST: bool = true;

@compute @workgroup_size(WORKGROUP)
fn self_collision_respond(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.particle_count) {
        return;
    }
    let p = params.particle_base + gid.x;
    if (self_collision_respond_item(p, sc_pass_src(PASS), sc_pass_dst(PASS, LAST), LAST)) {
        self_collision_moved();
    }
}
