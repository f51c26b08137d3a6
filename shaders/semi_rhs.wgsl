// Semi-implicit step, per particle: the filter's right-hand side
// dt (f + dt K v), K the springs' stiffness as the filter sees it. Twin:
// cpu::semi_implicit::rhs.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

// Bit of params.torque_compensation: the per-spring compensation (twin:
// gpu::layout::TORQUE_LOCAL).
const TORQUE_LOCAL: u32 = 1u;

// Twin: cpu::semi_implicit::touching.
fn touching(xp: vec3<f32>, clock: u32) -> bool {
    return find_contact(xp, CONTACT_SLOP, clock).found;
}

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
    let f = total_force(p, x[p], v[p], STATE_BUFFERS);
    // Σ ±K_s (v_i − v_j), gathered like gather_signed. With the torque
    // compensation a spring resists across itself only with the share its
    // tension gives it, unless it touches a collider; without, K_s = k I. Twin:
    // cpu::semi_implicit::jacobian_v.
    let rotation_free = (params.torque_compensation & TORQUE_LOCAL) != 0u;
    var acc = vec3<f32>(0.0);
    let clock = particle_clock(p);
    let begin = spring_adj(p);
    let end = spring_adj(p + 1u);
    for (var k = begin; k < end; k++) {
        let e = topo[params.spring_adj_entries + k];
        let sp = springs[e >> 1u];
        let frame = spring_transverse(sp.rest, x[sp.i].xyz, x[sp.j].xyz);
        // A spring with an end on a collider keeps k I (twin: touching).
        var c = 1.0;
        if (rotation_free && !touching(x[sp.i].xyz, clock) && !touching(x[sp.j].xyz, clock)) {
            c = frame.w;
        }
        let term = spring_kv(sp.k, c, frame.xyz, v[sp.i].xyz - v[sp.j].xyz);
        if ((e & 1u) == 0u) {
            acc += term;
        } else {
            acc -= term;
        }
    }
    let kv = acc;
    work[wi(W_RHS, p)] = vec4<f32>((f + kv * params.dt) * params.dt, 0.0);
    if (ZERO_DV) {
        work[wi(W_DV, p)] = vec4<f32>(0.0);
    }
}
