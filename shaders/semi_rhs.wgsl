// Semi-implicit step, per particle: the filter's right-hand side
// dt (f + dt K v), K the springs' stiffness as the filter sees it. Twin:
// cpu::semi_implicit::rhs.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/semi.wgsl"

// Dense filter: Δv starts at zero (pinned particles keep it). CG filter:
// Δv keeps the last step's value as the warm start.
override ZERO_DV: bool = true;

@compute @workgroup_size(WORKGROUP)
fn semi_rhs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicAdd(&status[sw(STATUS_STEP)], 1u);
    }
    if (p >= params.particle_count) {
        return;
    }
    semi_rhs_particle(p, ZERO_DV);
}
