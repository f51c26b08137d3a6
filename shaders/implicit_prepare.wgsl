// Implicit step, per particle: forces, constraint filter and z, right-hand
// side, block-diagonal preconditioner, warm-started Δv, and the partial
// term of δ0 = (Sb)ᵀP(Sb) in the w of W_RHS; with coarse levels, the
// particle's contributions to its aggregates' D. Twin:
// cpu::implicit::prepare.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"
#include "generated/grid_block.wgsl"

@compute @workgroup_size(WORKGROUP)
fn implicit_prepare(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicAdd(&status[STATUS_STEP], 1u);
        atomicStore(&status[STATUS_CG_ITERATIONS], 0u);
        atomicStore(&status[STATUS_CG_STOPPED], 0u);
    }
    // On a grid: one invocation per block of particles, which linearises
    // the springs itself (no spring pass).
    if (grid_gather_done(p)) {
        return;
    }
    // The spring pass's K v and blocks, in adjacency order.
    let x0 = x[p];
    let v0 = v[p];
    var kv = vec3<f32>(0.0);
    var pre = Sym3(vec3<f32>(v0.w), vec3<f32>(0.0));
    var levels = levels_start(p, v0.w);
    let begin = topo[p];
    let end = topo[p + 1u];
    let others = spring_adj_others();
    for (var k = begin; k < end; k++) {
        let e = topo[params.spring_adj_entries + k];
        let s = e >> 1u;
        let kvs = spring_work[si(S_KV, s)].xyz;
        kv += select(kvs, -kvs, (e & 1u) != 0u);
        let blk = spring_work[si(S_BLOCK, s)];
        pre = sym3_add_block(pre, blk);
        levels = levels_add(levels, topo[others + k], blk);
    }
    prepare_particle(p, x0, v0, total_force(p, x0, v0, STATE_BUFFERS), kv, pre, levels);
}

// A particle's contributions to its aggregates' D at both levels (twin:
// `levels` in cpu::implicit::prepare): its mass times I plus the blocks of
// its springs whose other end lies in another aggregate of that level.
struct Levels {
    own: vec2<u32>,
    d1: Sym3,
    d2: Sym3,
}

fn levels_start(p: u32, m: f32) -> Levels {
    let diag = Sym3(vec3<f32>(m), vec3<f32>(0.0));
    if (!COARSE) {
        return Levels(vec2<u32>(0u), diag, diag);
    }
    return Levels(vec2<u32>(coarse_of(LEVEL1_SIDE, p), coarse_of(LEVEL2_SIDE, p)), diag, diag);
}

// `l` plus the block `blk` of a spring whose other end is `other`.
fn levels_add(l: Levels, other: u32, blk: vec4<f32>) -> Levels {
    if (!COARSE) {
        return l;
    }
    var out = l;
    if (coarse_of(LEVEL1_SIDE, other) != l.own.x) {
        out.d1 = sym3_add_block(out.d1, blk);
    }
    if (coarse_of(LEVEL2_SIDE, other) != l.own.y) {
        out.d2 = sym3_add_block(out.d2, blk);
    }
    return out;
}

// The grid gather (generated/grid_block.wgsl): each particle's state; each
// spring's force, K v and block once; per particle their sums and the
// preconditioner's matrix.
struct BlockData {
    x: vec4<f32>,
    v: vec4<f32>,
}

alias SpringData = Linearised;

struct BlockAcc {
    f: vec3<f32>,
    kv: vec3<f32>,
    pre: Sym3,
    levels: Levels,
}

fn block_load(pt: GridPoint) -> BlockData {
    return BlockData(x[pt.index], v[pt.index]);
}

fn block_start(p: u32, own: BlockData) -> BlockAcc {
    return BlockAcc(
        vec3<f32>(0.0),
        vec3<f32>(0.0),
        Sym3(vec3<f32>(own.v.w), vec3<f32>(0.0)),
        levels_start(p, own.v.w),
    );
}

fn spring_load(inc: Incident, first: BlockData, second: BlockData) -> SpringData {
    return grid_linearise(inc, first.x.xyz, second.x.xyz, first.v.xyz, second.v.xyz);
}

fn block_term(acc: BlockAcc, own: BlockData, other: BlockData, inc: Incident, sd: SpringData) -> BlockAcc {
    var pre = acc.pre;
    var levels = acc.levels;
    if (inc.ok) {
        pre = sym3_add_block(pre, sd.blk);
        levels = levels_add(levels, inc.other, sd.blk);
    }
    return BlockAcc(acc.f + grid_term(sd.f, inc), acc.kv + grid_term(sd.kv, inc), pre, levels);
}

fn block_end(p: u32, own: BlockData, acc: BlockAcc) {
    let f = force_with_springs(p, acc.f, own.v.w, STATE_BUFFERS);
    prepare_particle(p, own.x, own.v, f, acc.kv, acc.pre, acc.levels);
}

// The rest of particle p's set-up from its state `x0`, `v0`, the total
// force `f` on it [N], the sum `kv` of its springs' K v, the matrix
// `pre` = m I plus its springs' blocks, and its coarse contributions.
fn prepare_particle(
    p: u32,
    x0: vec4<f32>,
    v0: vec4<f32>,
    f: vec3<f32>,
    kv: vec3<f32>,
    pre_in: Sym3,
    levels: Levels,
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
        if (c.found && (dot3(f, c.normal) < 0.0 || dot3(vp - c.velocity, c.normal) < 0.0)) {
            kind = FILTER_PLANE;
            normal = c.normal;
            friction = c.friction;
            // The approach speed relative to the collider.
            let vc = contact_velocity(x0.xyz, clock);
            z = normal * (-min(dot3(vp - vc, normal), 0.0));
        }
    }
    let rhs = (f + kv * params.dt) * params.dt;
    // Twin: Sym3::inverse, with its fallback to 1/m I.
    var pre = Sym3(vec3<f32>(1.0 / m), vec3<f32>(0.0));
    let inv = sym3_inverse(pre_in);
    if (inv.ok) {
        pre = inv.m;
    }
    if (GRID && (HAS_GROUND || HAS_SPHERES)) {
        work[wi(W_X_START, p)] = x0;
    }
    work[wi(W_Z, p)] = vec4<f32>(z, kind);
    work[wi(W_FILTER, p)] = vec4<f32>(normal, friction);
    work[wi(W_PRE_DIAG, p)] = vec4<f32>(pre.d, 0.0);
    work[wi(W_PRE_OFF, p)] = vec4<f32>(pre.o, 0.0);
    if (COARSE) {
        // The trace of the block-Jacobi block, for θ (coarse_setup).
        let trace = pre_in.d.x + pre_in.d.y + pre_in.d.z;
        work[wi(W_LEVEL1_D, p)] = vec4<f32>(levels.d1.d, 0.0);
        work[wi(W_LEVEL1_O, p)] = vec4<f32>(levels.d1.o, trace);
        work[wi(W_LEVEL2_D, p)] = vec4<f32>(levels.d2.d, 0.0);
        work[wi(W_LEVEL2_O, p)] = vec4<f32>(levels.d2.o, 0.0);
    }
    let dv = filter_apply(kind, normal, warm_start(p)) + z;
    work[wi(W_DV, p)] = vec4<f32>(dv, kind);
    let sb = filter_apply(kind, normal, rhs);
    work[wi(W_RHS, p)] = vec4<f32>(rhs, dot3(sb, sym3_mul(pre, sb)));
}
