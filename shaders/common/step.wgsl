// The per-item work of the explicit and semi-implicit steps, one function
// per item: called by their multi-dispatch kernels (an item per
// invocation) and by the workgroup kernels (cloth_explicit,
// cloth_semi_implicit: each invocation loops over its share of a phase's
// items), so each piece of the step is written once.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// Spring s's force on end i into S_FORCE (twin:
// cpu::forces::spring_forces), for the particles to gather.
fn spring_force_item(s: u32) {
    let sp = spring(s);
    let f = spring_force(sp, x[sp.i].xyz, x[sp.j].xyz, v[sp.i].xyz, v[sp.j].xyz);
    work[si(S_FORCE, s)] = vec4<f32>(f, 0.0);
}

// Symplectic Euler (twin: cpu::explicit::integrate) of a particle with
// state `x0` (w: inverse mass), `v0` under the total force `f` [N]:
// (x*, v*), v* = v + dt w f, x* = x + dt v*; a pinned particle keeps x
// and gets v* = 0.
fn predict(x0: vec4<f32>, v0: vec4<f32>, f: vec3<f32>) -> array<vec3<f32>, 2> {
    let w = x0.w;
    var vn = v0.xyz + f * (params.dt * w);
    var xn = x0.xyz;
    if (w > 0.0) {
        xn += vn * params.dt;
    } else {
        vn = vec3<f32>(0.0);
    }
    return array<vec3<f32>, 2>(xn, vn);
}

// Stores particle p's prediction for the fix-up and the step's end.
fn store_prediction(p: u32, xn: vec3<f32>, vn: vec3<f32>) {
    work[wi(W_X_PRED, p)] = vec4<f32>(xn, 0.0);
    work[wi(W_V_NEW, p)] = vec4<f32>(vn, 0.0);
}

// The end of particle p's explicit or semi-implicit step (twin:
// cpu::finish_step): the velocity rebuilt from the fixed-up position if
// the fix-up moved anything, collisions (pins: towards their goals), the
// clock advanced, the state stored unless it is not finite.
fn finish_particle(p: u32) {
    let x0 = x[p];
    let w = x0.w;
    // The fix-up's result section (X_PRED when there was none).
    var xp = work[wi(atomicLoad(&status[sw(STATUS_FIXUP_RESULT)]), p)].xyz;
    var vp = work[wi(W_V_NEW, p)].xyz;
    let clock = particle_clock(p);
    if (w > 0.0) {
        if (atomicLoad(&status[sw(STATUS_FIXUP_MOVED)]) != 0u) {
            vp = (xp - x0.xyz) * (1.0 / params.dt);
        }
        let r = collide_particle(x0.xyz, xp, vp, clock);
        xp = r[0];
        vp = r[1];
    } else {
        let r = pin_step(p, clock, x0.xyz);
        xp = r[0];
        vp = r[1];
    }
    advance_clock(p, clock, vec3<f32>(0.0));
    _ = store_state(p, xp, vp, w, v[p].w);
}

// Semi-implicit: particle p's velocity v + Δv (free particles; pinned: 0)
// and the predicted position x + dt v, for the fix-up and the step's end
// (twin: cpu::semi_implicit::integrate).
fn semi_integrate_particle(p: u32) {
    var vn = vec3<f32>(0.0);
    var xn = x[p].xyz;
    if (x[p].w > 0.0) {
        vn = v[p].xyz + work[wi(W_DV, p)].xyz;
        xn += vn * params.dt;
    }
    store_prediction(p, xn, vn);
}

// Semi-implicit dense filter, filter position k (twin:
// cpu::filter::DenseFilter::apply): Δv of its particle = row k of W times
// the right-hand side. `dense` holds Wᵀ from params.dense_base, then the
// filter order (global particle indices, as f32 bits).
fn filter_dense_row(k: u32) {
    let n = params.filter_count;
    let base = params.dense_base;
    let order = base + n * n;
    var acc = vec3<f32>(0.0);
    for (var q = 0u; q < n; q++) {
        let particle = bitcast<u32>(dense(order + q));
        acc += work[wi(W_RHS, particle)].xyz * dense(base + q * n + k);
    }
    work[wi(W_DV, bitcast<u32>(dense(order + k)))] = vec4<f32>(acc, 0.0);
}
