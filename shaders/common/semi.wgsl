// The semi-implicit step's right-hand side for one particle (twin:
// cpu::semi_implicit::rhs): shared by the semi_rhs kernel and the
// semi-implicit workgroup kernel.

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

// Particle p's right-hand side dt (f + dt K v) into W_RHS, K the springs'
// stiffness as the filter sees it (and the linear bending operator's
// −Q); with `zero_dv` its Δv starts at zero
// (the dense filter: pinned particles keep it), else Δv keeps the last
// step's value as the CG filter's warm start.
fn semi_rhs_particle(p: u32, zero_dv: bool) {
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
        let e = topo(params.spring_adj_entries + k);
        let sp = spring(e >> 1u);
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
    var kv = acc;
    if (has_bending()) {
        kv -= bending_product(p, BENDING_V);
    }
    work[wi(W_RHS, p)] = vec4<f32>((f + kv * params.dt) * params.dt, 0.0);
    if (zero_dv) {
        work[wi(W_DV, p)] = vec4<f32>(0.0);
    }
}
