// The implicit step's per-item work (twin: cpu::implicit) in the general
// (adjacency) layout: the body of each multi-dispatch kernel
// (implicit_springs, implicit_prepare, implicit_finish) as a function, so
// that the kernel and cloth_implicit, which runs the whole step in one
// workgroup, run the same code. The grid forms stay in the kernel files.
// `coarse` says whether the cloth has coarse levels: the kernels pass
// their COARSE, cloth_implicit reads it from params.coarse.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"

// The step's status words at its start: one more step, CG not yet run.
// Once per step, by one invocation.
fn implicit_step_start() {
    atomicAdd(&status[sw(STATUS_STEP)], 1u);
    // Self-collision's: nothing moved yet; its passes start from, and
    // end in, the prediction's section.
    atomicStore(&status[sw(STATUS_FIXUP_MOVED)], 0u);
    atomicStore(&status[sw(STATUS_FIXUP_RESULT)], W_X_ALT);
    atomicStore(&status[sw(STATUS_CG_ITERATIONS)], 0u);
    atomicStore(&status[sw(STATUS_CG_STOPPED)], 0u);
}

// Spring s linearised at the start of the step (twin: the spring loop of
// cpu::implicit::springs): its block, K v and force into S_BLOCK, S_KV
// and S_FORCE.
fn implicit_springs_item(s: u32) {
    let sp = spring(s);
    let xi = x[sp.i].xyz;
    let xj = x[sp.j].xyz;
    let vi = v[sp.i].xyz;
    let vj = v[sp.j].xyz;
    let lin = linearise(sp.rest, sp.k, sp.kd, xi, xj, vi, vj);
    work[si(S_BLOCK, s)] = lin.blk;
    work[si(S_KV, s)] = vec4<f32>(lin.kv, 0.0);
    work[si(S_FORCE, s)] = vec4<f32>(lin.f, 0.0);
}

// The set-up of particle p from the spring pass's K v and blocks, in
// adjacency order (twin: the particle loop of cpu::implicit::prepare).
fn implicit_prepare_item(p: u32, coarse: bool) {
    let x0 = x[p];
    let v0 = v[p];
    var kv = vec3<f32>(0.0);
    var pre = pre_start(p, v0.w);
    var levels = levels_start(p, v0.w, coarse);
    let begin = spring_adj(p);
    let end = spring_adj(p + 1u);
    let others = spring_adj_others();
    for (var k = begin; k < end; k++) {
        let e = topo(params.spring_adj_entries + k);
        let s = e >> 1u;
        let kvs = work[si(S_KV, s)].xyz;
        kv += select(kvs, -kvs, (e & 1u) != 0u);
        let blk = work[si(S_BLOCK, s)];
        pre = sym3_add_block(pre, blk);
        levels = levels_add(levels, topo(others + k), blk, coarse);
    }
    let f = total_force(p, x0, v0, STATE_BUFFERS);
    prepare_particle(p, x0, v0, f, kv, pre, levels, coarse);
}

// The start of particle p's block-Jacobi block: its mass `m` [kg] times
// I, plus the linear bending operator's (dt² + dt β) Q_pp I (twin: the
// start of the particle loop of cpu::implicit::prepare).
fn pre_start(p: u32, m: f32) -> Sym3 {
    var d = m;
    if (has_bending()) {
        d += bending_scaled_diagonal(p);
    }
    return Sym3(vec3<f32>(d), vec3<f32>(0.0));
}

// The rest of particle p's set-up from its state `x0`, `v0`, the total
// force `f` on it [N], the sum `kv_springs` of its springs' K v (the
// bending operator's −Q v is added here), the matrix `pre` = pre_start
// plus its springs' blocks, and its coarse contributions (stored when
// `coarse`).
fn prepare_particle(
    p: u32,
    x0: vec4<f32>,
    v0: vec4<f32>,
    f: vec3<f32>,
    kv_springs: vec3<f32>,
    pre_in: Sym3,
    levels: Levels,
    coarse: bool,
) {
    let m = v0.w;
    let vp = v0.xyz;
    var kind = FILTER_FREE;
    var normal = vec3<f32>(0.0);
    var friction = 0.0;
    var z = vec3<f32>(0.0);
    let clock = particle_clock(p);
    if (x0.w <= 0.0) {
        kind = FILTER_FIXED;
        // A moving pin's prescribed change of velocity (Baraff–Witkin's z).
        z = pin_velocity(p, clock, x0.xyz) - vp;
    } else {
        let c = find_contact(x0.xyz, CONTACT_SLOP, clock);
        if (c.found && work[wi(W_DV_PREV, p)].w == HELD_NEXT) {
            // Static friction held it at the end of the last step.
            kind = FILTER_HELD;
            normal = c.normal;
            friction = c.friction;
            z = c.velocity - vp;
        } else if (c.found && (dot3(f, c.normal) < 0.0 || dot3(vp - c.velocity, c.normal) < 0.0)) {
            kind = FILTER_PLANE;
            normal = c.normal;
            friction = c.friction;
            // The approach speed relative to the collider.
            z = normal * (-min(dot3(vp - c.velocity, normal), 0.0));
        }
    }
    var kv = kv_springs;
    if (has_bending()) {
        kv -= bending_product(p, BENDING_V);
    }
    var rhs = (f + kv * params.dt) * params.dt;
    if (kind == FILTER_PLANE) {
        // A sliding contact's friction from the last step's normal force.
        rhs += contact_friction(p);
    }
    // Twin: Sym3::inverse, with its fallback to 1/m I.
    var pre = Sym3(vec3<f32>(1.0 / m), vec3<f32>(0.0));
    let inv = sym3_inverse(pre_in);
    if (inv.ok) {
        pre = inv.m;
    }
    if (GRID && (has_ground() || has_spheres())) {
        work[wi(W_X_START, p)] = x0;
    }
    work[wi(W_Z, p)] = vec4<f32>(z, kind);
    work[wi(W_FILTER, p)] = vec4<f32>(normal, friction);
    work[wi(W_PRE_DIAG, p)] = vec4<f32>(pre.d, 0.0);
    work[wi(W_PRE_OFF, p)] = vec4<f32>(pre.o, 0.0);
    if (coarse) {
        store_levels(p, levels, pre_in.d.x + pre_in.d.y + pre_in.d.z);
    }
    let dv = filter_apply(kind, normal, warm_start(p)) + z;
    work[wi(W_DV, p)] = vec4<f32>(dv, kind);
    let sb = filter_apply(kind, normal, rhs);
    work[wi(W_RHS, p)] = vec4<f32>(rhs, dot3(sb, sym3_mul(pre, sb)));
}

// CG_MAX_ITERATIONS takes the step's count. Once per step, by one
// invocation, after CG.
fn record_cg_max() {
    atomicMax(&status[sw(STATUS_CG_MAX_ITERATIONS)], atomicLoad(&status[sw(STATUS_CG_ITERATIONS)]));
}

// The friction impulse [N·s] particle p takes in this step if it slides
// on a contact: W_CLOCK's yzw (twin: Workspace::friction).
fn contact_friction(p: u32) -> vec3<f32> {
    return work[wi(W_CLOCK, p)].yzw;
}

// Particle p's state at the end of an implicit step before collisions
// (twin: cpu::implicit::finish up to its self-collision): v += Δv, and
// at a filtered contact the friction of the next step from this one's
// constraint impulse (twin: cpu::implicit::contact_friction: whether
// static friction holds it, in W_DV_PREV's w, or the impulse it slides
// with, in W_CLOCK's yzw); then x += dt v for a free particle, the pin's
// step for a pinned one. Returns (x, v). It reads its neighbours' Δv,
// never their x or v, so the particles may finish in any order.
fn implicit_predict_item(p: u32) -> array<vec3<f32>, 2> {
    let x0 = x[p];
    let v0 = v[p];
    let clock = particle_clock(p);
    let vp = v0.xyz + work[wi(W_DV, p)].xyz;
    // Only colliders make plane and held filters: without them the
    // contact code is compiled out (lavapipe runs a branch no lane takes).
    if (has_ground() || has_spheres()) {
        let kind = work[wi(W_Z, p)].w;
        var held = false;
        var friction = vec3<f32>(0.0);
        if (kind == FILTER_PLANE || kind == FILTER_HELD) {
            let filt = work[wi(W_FILTER, p)];
            let normal = filt.xyz;
            let r = apply_a(W_DV, p) - work[wi(W_RHS, p)].xyz;
            let pushed = dot3(r, normal);
            let budget = filt.w * pushed;
            if (pushed > 0.0 && budget > 0.0) {
                if (kind == FILTER_HELD) {
                    let resisted = r - normal * pushed;
                    let needed = len3(resisted);
                    held = needed <= budget;
                    if (!held) {
                        friction = resisted * (budget / needed);
                    }
                } else {
                    let rel = vp - contact_velocity(x0.xyz, clock);
                    let tangential = rel - normal * dot3(rel, normal);
                    let speed = len3(tangential);
                    held = speed * v0.w <= budget;
                    if (!held) {
                        friction = tangential * (-budget / speed);
                    }
                }
            }
        }
        let prev = work[wi(W_DV_PREV, p)].xyz;
        work[wi(W_DV_PREV, p)] = vec4<f32>(prev, select(0.0, HELD_NEXT, held));
        work[wi(W_CLOCK, p)] = vec4<f32>(bitcast<f32>(clock), friction);
    }
    if (x0.w > 0.0) {
        return array<vec3<f32>, 2>(x0.xyz + vp * params.dt, vp);
    }
    return pin_step(p, clock, x0.xyz);
}

// The end of particle p's implicit step from its predicted state `xp`,
// `vp` (twin: the end of cpu::implicit::finish): collisions for a free
// particle, the clock advanced, the state stored.
fn implicit_end_item(p: u32, xp: vec3<f32>, vp: vec3<f32>) {
    let x0 = x[p];
    let clock = particle_clock(p);
    var r = array<vec3<f32>, 2>(xp, vp);
    if (x0.w > 0.0) {
        r = collide_particle(x0.xyz, xp, vp, clock);
    }
    advance_clock(p, clock, contact_friction(p));
    _ = store_state(p, r[0], r[1], x0.w, v[p].w);
}

// The implicit step's end for particle p without self-collision.
fn implicit_finish_item(p: u32) {
    let r = implicit_predict_item(p);
    implicit_end_item(p, r[0], r[1]);
}

// With self-collision, the prediction stored for its passes: x where they
// start from (STATUS_FIXUP_RESULT, set to W_X_ALT by implicit_step_start),
// v in W_V_NEW.
fn implicit_store_prediction(p: u32) {
    let r = implicit_predict_item(p);
    work[wi(W_X_ALT, p)] = vec4<f32>(r[0], 0.0);
    work[wi(W_V_NEW, p)] = vec4<f32>(r[1], 0.0);
}

// With self-collision, particle p's step end after its passes (twin:
// cpu::self_collision::project's v += Δx / dt, where it moved anything,
// then the end of cpu::implicit::finish).
fn implicit_project_item(p: u32) {
    let xp = work[wi(W_X_ALT, p)].xyz;
    var vp = work[wi(W_V_NEW, p)].xyz;
    if (x[p].w > 0.0 && atomicLoad(&status[sw(STATUS_FIXUP_MOVED)]) != 0u) {
        vp += unseen3((xp - work[wi(W_SC_A, p)].xyz) * (1.0 / params.dt));
    }
    implicit_end_item(p, xp, vp);
}
