// Semi-implicit step, per particle: the filter's right-hand side
// dt (f + dt H v), H the stiffness Laplacian. Twin:
// cpu::semi_implicit::rhs.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// Dense filter: Δv starts at zero (pinned particles keep it). CG filter:
// Δv keeps the last step's value as the warm start.
override ZERO_DV: bool = true;

@compute @workgroup_size(WORKGROUP)
fn semi_rhs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicAdd(&status[STATUS_STEP], 1u);
    }
    if (p >= params.particle_count) {
        return;
    }
    let f = total_force(p, x[p], v[p], STATE_BUFFERS);
    // Σ ±k (v_i − v_j), gathered like gather_signed, then negated.
    var acc = vec3<f32>(0.0);
    let begin = topo[p];
    let end = topo[p + 1u];
    for (var k = begin; k < end; k++) {
        let e = topo[params.spring_adj_entries + k];
        let sp = springs[e >> 1u];
        let term = (v[sp.i].xyz - v[sp.j].xyz) * sp.k;
        if ((e & 1u) == 0u) {
            acc += term;
        } else {
            acc -= term;
        }
    }
    let hv = -acc;
    work[wi(W_RHS, p)] = vec4<f32>((f + hv * params.dt) * params.dt, 0.0);
    if (ZERO_DV) {
        work[wi(W_DV, p)] = vec4<f32>(0.0);
    }
}
