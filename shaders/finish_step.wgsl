// End of an explicit or semi-implicit step: rebuild the velocity from the
// fixed-up position if the fix-up moved anything, resolve collisions (pins:
// towards their goals), advance the clock, store.
// Twin: cpu::finish_step.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

@compute @workgroup_size(WORKGROUP)
fn finish_step(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= params.particle_count) {
        return;
    }
    let x0 = x[p];
    let w = x0.w;
    // The fix-up's result section (X_PRED when there was none).
    var xp = work[wi(atomicLoad(&status[STATUS_FIXUP_RESULT]), p)].xyz;
    var vp = work[wi(W_V_NEW, p)].xyz;
    let clock = particle_clock(p);
    if (w > 0.0) {
        if (atomicLoad(&status[STATUS_FIXUP_MOVED]) != 0u) {
            vp = (xp - x0.xyz) * (1.0 / params.dt);
        }
        let r = collide_particle(xp, vp, clock);
        xp = r[0];
        vp = r[1];
    } else {
        let r = pin_step(p, clock, x0.xyz);
        xp = r[0];
        vp = r[1];
    }
    advance_clock(p, clock);
    _ = store_state(p, xp, vp, w, v[p].w);
}
