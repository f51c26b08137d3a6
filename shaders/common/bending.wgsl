// The linear bending model (src/bending.rs): its force, its operator's
// product and diagonal for one particle, each the twin of the CPU function
// of the same name in cpu::forces with the operations in the same order
// and every product rounded before the sum it feeds (unseen3, unseen1), as
// the CPU rounds it. Called where the springs' terms are: total_force
// (every integrator's force), the implicit and semi-implicit right-hand
// sides (−Q v), their preconditioners' diagonals and the CG product
// (apply_a), on both the multi-dispatch and the workgroup kernels.
//
// `Q`'s rows are in `model` (see ClothArrays::bending in src/gpu/build.rs):
// particle p's entries k from offset p to offset p + 1 (the offsets' words
// from params.bending_rows.x), each the other particle (within the cloth,
// from word params.bending_rows.y) and `Q_pj` [N/m] as f32 bits (from word
// params.bending_rows.z). A row holds the off-diagonal entries only, each
// applied to a difference: (Q y)_p = Σ_j Q_pj (y_j − y_p).

#include "common/bindings.wgsl"

// The velocities `v` as the vector of bending_product (the right-hand
// sides' −Q v); any other value is a `work` section.
const BENDING_V: u32 = 0xffffffffu;

// Particle p's entries: [first, end).
fn bending_row(p: u32) -> vec2<u32> {
    let at = params.bending_rows.x + local(p);
    return vec2<u32>(topo(at), topo(at + 1u));
}

// Entry k's other particle (a global index, as x and v take it).
fn bending_column(k: u32) -> u32 {
    return params.particle_base + topo(params.bending_rows.y + k);
}

// Entry k's Q_pj [N/m].
fn bending_coefficient(k: u32) -> f32 {
    return bitcast<f32>(topo(params.bending_rows.z + k));
}

// Particle i's value of the vector in `sec` (BENDING_V: its velocity).
fn bending_vector(sec: u32, i: u32) -> vec3<f32> {
    if (sec == BENDING_V) {
        return v[i].xyz;
    }
    return work[wi(sec, i)].xyz;
}

// Twin: cpu::forces::bending_force. The linear bending force on particle
// p [N], −(Q (x + β v))_p, summed per entry as
// Q_pj ((x_j − x_p) + β (v_j − v_p)); the state from `sec` (see state_x).
fn bending_force(p: u32, sec: u32) -> vec3<f32> {
    let xp = state_x(p, sec);
    let vp = state_v(p, sec);
    let beta = params.bending.x;
    let row = bending_row(p);
    var acc = vec3<f32>(0.0);
    for (var k = row.x; k < row.y; k++) {
        let j = bending_column(k);
        let d = (state_x(j, sec) - xp) + unseen3((state_v(j, sec) - vp) * beta);
        acc -= unseen3(d * bending_coefficient(k));
    }
    return acc;
}

// Twin: cpu::forces::bending_product. (Q y)_p = Σ_j Q_pj (y_j − y_p) for
// the vector y in `sec` (BENDING_V: the velocities).
fn bending_product(p: u32, sec: u32) -> vec3<f32> {
    let yp = bending_vector(sec, p);
    let row = bending_row(p);
    var acc = vec3<f32>(0.0);
    for (var k = row.x; k < row.y; k++) {
        acc += unseen3((bending_vector(sec, bending_column(k)) - yp) * bending_coefficient(k));
    }
    return acc;
}

// Twin: cpu::forces::bending_diagonal. Q_pp = −Σ_j Q_pj [N/m], summed in
// column order.
fn bending_diagonal(p: u32) -> f32 {
    let row = bending_row(p);
    var acc = 0.0;
    for (var k = row.x; k < row.y; k++) {
        acc -= bending_coefficient(k);
    }
    return acc;
}

// (dt² + dt β) Q_pp [kg]: the operator's part of the diagonal of the
// implicit and semi-implicit matrices, rounded before it is added.
fn bending_scaled_diagonal(p: u32) -> f32 {
    return unseen1(bending_diagonal(p) * params.bending.y);
}

// `acc` plus (dt² + dt β) (Q y)_p for the vector y in work section `sec`
// (twin: the bending part of cpu::cg::apply_a_unfiltered); `acc` itself
// without the bending model.
fn add_bending_product(acc: vec3<f32>, sec: u32, p: u32) -> vec3<f32> {
    if (!has_bending()) {
        return acc;
    }
    return acc + unseen3(bending_product(p, sec) * params.bending.y);
}
