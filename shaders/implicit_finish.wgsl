// Implicit step end: v += Δv, friction at filtered contacts from the
// constraint impulse, x += dt v, collisions (pins: towards their goals),
// the clock, store. Twin:
// cpu::implicit::finish.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn implicit_finish(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicMax(&status[STATUS_CG_MAX_ITERATIONS], atomicLoad(&status[STATUS_CG_ITERATIONS]));
    }
    if (p >= params.particle_count) {
        return;
    }
    let x0 = x[p];
    let v0 = v[p];
    let clock = particle_clock(p);
    var vp = v0.xyz + work[wi(W_DV, p)].xyz;
    // Only colliders make plane filters: without them the contact code
    // is compiled out (lavapipe runs a branch no lane takes).
    if ((HAS_GROUND || HAS_SPHERES) && work[wi(W_Z, p)].w == FILTER_PLANE) {
        let filt = work[wi(W_FILTER, p)];
        let normal = filt.xyz;
        let impulse = dot3(apply_a(W_DV, p) - work[wi(W_RHS, p)].xyz, normal);
        if (impulse > 0.0) {
            // Friction on the velocity relative to the collider.
            let vc = contact_velocity(x0.xyz, clock);
            let rel = vp - vc;
            let tangential = rel - normal * dot3(rel, normal);
            let speed = len3(tangential);
            let loss = filt.w * impulse / v0.w;
            var kept = 0.0;
            if (speed > loss && speed > TINY) {
                kept = (speed - loss) / speed;
            }
            vp = vc + unseen3(normal * dot3(rel, normal) + tangential * kept);
        }
    }
    var xp = x0.xyz;
    if (x0.w > 0.0) {
        xp += vp * params.dt;
        let r = collide_particle(xp, vp, clock);
        xp = r[0];
        vp = r[1];
    } else {
        let r = pin_step(p, clock, xp);
        xp = r[0];
        vp = r[1];
    }
    advance_clock(p, clock);
    _ = store_state(p, xp, vp, x0.w, v0.w);
}
