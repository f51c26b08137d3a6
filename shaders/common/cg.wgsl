// Shared by the CG kernels (implicit integrator and the scalable
// semi-implicit filter). Twins: cpu::cg, cpu::implicit and cpu::mat3.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// Aggregate a's entry of `work` section `section` (the coarse levels,
// common/coarse.wgsl, keep one entry per aggregate of both levels, level
// 1's first, where the particles keep one per particle).
fn wa(section: u32, a: u32) -> u32 {
    return wi(section, params.particle_base + a);
}

// Twin: implicit::Filter::apply. `f` is W_Z's w (kind), `n` W_FILTER's xyz.
fn filter_apply(kind: f32, n: vec3<f32>, a: vec3<f32>) -> vec3<f32> {
    if (!has_filter()) {
        return a;
    }
    if (kind == FILTER_FIXED) {
        return vec3<f32>(0.0);
    }
    // Only colliders make plane filters (lavapipe runs a branch no lane
    // takes, so it is compiled out without them).
    if ((has_ground() || has_spheres()) && kind == FILTER_PLANE) {
        return a - n * dot3(a, n);
    }
    return a;
}

// Particle p's filter kind (W_Z's w; free without filters).
fn filter_kind(p: u32) -> f32 {
    if (!has_filter()) {
        return FILTER_FREE;
    }
    return work[wi(W_Z, p)].w;
}

// S_p a for particle p of filter kind `kind`: only a plane filter loads
// its normal.
fn filter_with(kind: f32, p: u32, a: vec3<f32>) -> vec3<f32> {
    var n = vec3<f32>(0.0);
    if (has_filter() && (has_ground() || has_spheres()) && kind == FILTER_PLANE) {
        n = work[wi(W_FILTER, p)].xyz;
    }
    return filter_apply(kind, n, a);
}

fn filter_of(p: u32, a: vec3<f32>) -> vec3<f32> {
    return filter_with(filter_kind(p), p, a);
}

// The CG warm start of particle p: the last two Δv extrapolated,
// 2 Δv − Δv_prev (twin: cpu::implicit::warm_start), which
// becomes the new Δv_prev. Unfiltered: the caller filters it.
fn warm_start(p: u32) -> vec3<f32> {
    let dv_last = work[wi(W_DV, p)].xyz;
    let guess = dv_last * 2.0 - work[wi(W_DV_PREV, p)].xyz;
    work[wi(W_DV_PREV, p)] = vec4<f32>(dv_last, 0.0);
    return guess;
}

// A symmetric 3×3 matrix: diagonal (xx, yy, zz), off-diagonal (xy, xz, yz).
struct Sym3 {
    d: vec3<f32>,
    o: vec3<f32>,
}

// Twin: mat3::Sym3::inverse; `ok` is false where the CPU returns None.
struct Sym3Inverse {
    m: Sym3,
    ok: bool,
}

fn sym3_inverse(a: Sym3) -> Sym3Inverse {
    let xx = a.d.x;
    let yy = a.d.y;
    let zz = a.d.z;
    let xy = a.o.x;
    let xz = a.o.y;
    let yz = a.o.z;
    let c_xx = yy * zz - yz * yz;
    let c_xy = xz * yz - xy * zz;
    let c_xz = xy * yz - xz * yy;
    let det = xx * c_xx + xy * c_xy + xz * c_xz;
    let scale = max(max(abs(xx), abs(yy)), abs(zz));
    let floor = TINY * scale * scale * scale;
    if (!(finite1(det) && det > floor)) {
        return Sym3Inverse(a, false);
    }
    let inv = 1.0 / det;
    return Sym3Inverse(
        Sym3(
            vec3<f32>(c_xx * inv, (xx * zz - xz * xz) * inv, (xx * yy - xy * xy) * inv),
            vec3<f32>(c_xy * inv, c_xz * inv, (xy * xz - xx * yz) * inv),
        ),
        true,
    );
}

// `a` unchanged, through an xor with a zero the compiler cannot see (the
// unused fourth stiffness, which the host sets to 0). WGSL has no
// `precise`: Mesa rewrites float expressions it can see through, so a
// spring's block computed and used in one kernel (as the grid kernels do)
// rounded differently from the same block loaded from memory and from the
// CPU's. Passing it through here makes it as opaque as a load.
fn unseen4(a: vec4<f32>) -> vec4<f32> {
    return bitcast<vec4<f32>>(bitcast<vec4<u32>>(a) ^ vec4<u32>(bitcast<u32>(params.kind_k[3])));
}

// A spring linearised at the start of an implicit step: its CG block
// (m, a), B = a I + m mᵀ, K_s u, the product of its stiffness matrix with
// u = v_i − v_j, on end i, and its force on end i (twin:
// cpu::implicit::springs).
struct Linearised {
    blk: vec4<f32>,
    kv: vec3<f32>,
    f: vec3<f32>,
}

// The spring's direction (end j to end i; zero when degenerate) in xyz and
// the share max(0, 1 − L/l) of its stiffness acting across it in w. Twin:
// cpu::forces::spring_frame and cpu::implicit::transverse.
fn spring_transverse(rest: f32, xi: vec3<f32>, xj: vec3<f32>) -> vec4<f32> {
    let d = xi - xj;
    let l = len3(d);
    var dir = vec3<f32>(0.0);
    var transverse = 0.0;
    if (l > TINY) {
        dir = d / l;
        transverse = max(1.0 - rest / l, 0.0);
    }
    return vec4<f32>(dir, transverse);
}

// K_s u = −k (c u + (1 − c) n (n·u)), u = v_i − v_j. Twin:
// cpu::implicit::spring_kv.
fn spring_kv(k: f32, c: f32, dir: vec3<f32>, u: vec3<f32>) -> vec3<f32> {
    let k_long = k * (1.0 - c);
    return -(u * (k * c) + dir * (k_long * dot3(dir, u)));
}

fn linearise(
    rest: f32,
    k: f32,
    kd: f32,
    xi: vec3<f32>,
    xj: vec3<f32>,
    vi: vec3<f32>,
    vj: vec3<f32>,
) -> Linearised {
    let dt = params.dt;
    let dt2 = dt * dt;
    let frame = spring_transverse(rest, xi, xj);
    let dir = frame.xyz;
    let transverse = frame.w;
    let a = dt2 * k * transverse;
    let b = dt2 * k - a + dt * kd;
    let m = dir * sqrt(max(b, 0.0));
    let kv = spring_kv(k, transverse, dir, vi - vj);
    return Linearised(
        unseen4(vec4<f32>(m, a)),
        unseen4(vec4<f32>(kv, 0.0)).xyz,
        spring_force_of(rest, k, kd, xi, xj, vi, vj),
    );
}

// Grid spring `inc` linearised from its ends' state (end i first).
fn grid_linearise(inc: Incident, xi: vec3<f32>, xj: vec3<f32>, vi: vec3<f32>, vj: vec3<f32>) -> Linearised {
    return linearise(inc.rest, params.kind_k[inc.kind], params.kind_kd[inc.kind], xi, xj, vi, vj);
}

// The block (m, a) of grid spring `inc` from its ends' positions (end i
// first): the kernels compute it where they use it rather than load it,
// which on lavapipe costs more. None (zero) with CONSTANT_BLOCKS, whose
// blocks come from the parameters.
fn grid_spring_block(inc: Incident, xi: vec3<f32>, xj: vec3<f32>) -> vec4<f32> {
    if (CONSTANT_BLOCKS) {
        return vec4<f32>(0.0);
    }
    return grid_linearise(inc, xi, xj, vec3<f32>(0.0), vec3<f32>(0.0)).blk;
}

// Twin: Sym3::add_iso_aniso(a, 1, m) for the block (m, a) `blk`.
fn sym3_add_block(s: Sym3, blk: vec4<f32>) -> Sym3 {
    let a = blk.w;
    let m = blk.xyz;
    return Sym3(
        vec3<f32>(s.d.x + (a + m.x * m.x), s.d.y + (a + m.y * m.y), s.d.z + (a + m.z * m.z)),
        vec3<f32>(s.o.x + m.x * m.y, s.o.y + m.x * m.z, s.o.z + m.y * m.z),
    );
}

// Twin: mat3::Sym3::mul.
fn sym3_mul(m: Sym3, a: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        m.d.x * a.x + m.o.x * a.y + m.o.y * a.z,
        m.o.x * a.x + m.d.y * a.y + m.o.z * a.z,
        m.o.y * a.x + m.o.z * a.y + m.d.z * a.z,
    );
}

// Twin: mat3::Sym3::mul with the preconditioner of particle p
// (diag = xx, yy, zz; off = xy, xz, yz).
fn precond_mul(p: u32, a: vec3<f32>) -> vec3<f32> {
    return sym3_mul(Sym3(work[wi(W_PRE_DIAG, p)].xyz, work[wi(W_PRE_OFF, p)].xyz), a);
}

// `acc` plus ±B_s (a_i − a_j) of grid spring `t` (a row of the grid
// incidence table in physics.wgsl) at particle p, whose start-of-step
// position is `xp`.
fn grid_apply_term(
    acc: vec3<f32>,
    sec: u32,
    p: u32,
    rc: vec2<i32>,
    own: vec3<f32>,
    xp: vec3<f32>,
    t: vec4<i32>,
) -> vec3<f32> {
    let inc = grid_incident(p, rc, t);
    var xo = vec3<f32>(0.0);
    if (!CONSTANT_BLOCKS) {
        xo = work[wi(W_X_START, inc.other)].xyz;
    }
    let blk = grid_spring_block(inc, select(xp, xo, inc.at_j), select(xo, xp, inc.at_j));
    return grid_apply_with(acc, inc, own, work[wi(sec, inc.other)].xyz, blk);
}

// `acc` plus ±B_s (a_i − a_j) of grid spring `inc`, whose block is `blk`
// (see grid_spring_block), at a particle whose vector value is `own`, its
// neighbour's `other`.
fn grid_apply_with(
    acc: vec3<f32>,
    inc: Incident,
    own: vec3<f32>,
    other: vec3<f32>,
    blk: vec4<f32>,
) -> vec3<f32> {
    let d = select(own - other, other - own, inc.at_j);
    var y: vec3<f32>;
    if (CONSTANT_BLOCKS) {
        // m = 0: the general kernels' d a + 0 (0·d), to within the sign
        // of a zero.
        y = d * params.kind_a[inc.kind];
    } else {
        y = d * blk.w + blk.xyz * dot3(blk.xyz, d);
    }
    // `a − y` is `a + (−y)` exactly.
    return acc + grid_term(y, inc);
}

// (A a)_p, unfiltered, for the vector in work section `sec`: m a_p, then
// ±B_s (a_i − a_j) over the incident springs in adjacency order — the order
// in which the CPU's scatter reaches particle p. B_s = a I + m mᵀ from the
// block (m, a) (twin: SpringBlock::apply). Four loads per spring. Then the
// linear bending operator's (dt² + dt β) (Q a)_p (add_bending_product).
fn apply_a(sec: u32, p: u32) -> vec3<f32> {
    let own = work[wi(sec, p)].xyz;
    var acc = own * v[p].w;
    if (GRID) {
        // The same terms in the same order. The grid kernels that run
        // during CG gather by block (generated/grid_block.wgsl); this path
        // serves implicit_finish, which overwrites the positions as it
        // goes: the blocks come from the start-of-step copy.
        let rc = grid_row_col(p);
        var xp = vec3<f32>(0.0);
        if (!CONSTANT_BLOCKS) {
            xp = work[wi(W_X_START, p)].xyz;
        }
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(-1, 0, 1, 1));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(0, -1, 0, 1));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(0, 1, 0, 0));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(1, 0, 1, 0));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(-1, -1, 2, 1));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(-1, 1, 3, 1));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(1, -1, 3, 0));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(1, 1, 2, 0));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(-2, 0, 5, 1));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(0, -2, 4, 1));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(0, 2, 4, 0));
        acc = grid_apply_term(acc, sec, p, rc, own, xp, vec4<i32>(2, 0, 5, 0));
        return add_bending_product(acc, sec, p);
    }
    let begin = spring_adj(p);
    let end = spring_adj(p + 1u);
    let others = spring_adj_others();
    for (var k = begin; k < end; k++) {
        let e = topo(params.spring_adj_entries + k);
        let at_j = (e & 1u) != 0u;
        let other = work[wi(sec, topo(others + k))].xyz;
        let d = select(own - other, other - own, at_j);
        let blk = work[si(S_BLOCK, e >> 1u)];
        let y = d * blk.w + blk.xyz * dot3(blk.xyz, d);
        // `a − y` is `a + (−y)` exactly.
        acc += select(y, -y, at_j);
    }
    return add_bending_product(acc, sec, p);
}

// The CG set-up of particle p, whose Δv (with its filter kind in w) is
// `dv`, from (A Δv)_p, unfiltered, `adv` (twin: the particle loop of
// cpu::cg::init): r = S b − S A Δv, and without coarse levels s = S P r
// with ρ's term r·s in r's w (with them cg_update's first call computes s and
// ρ's terms); a zero previous direction and product.
fn cg_init_end(p: u32, dv: vec4<f32>, adv: vec3<f32>, coarse: bool) {
    let kind = dv.w;
    let q = filter_with(kind, p, adv);
    let r = filter_with(kind, p, work[wi(W_RHS, p)].xyz) - q;
    if (coarse) {
        work[wi(W_R, p)] = vec4<f32>(r, 0.0);
    } else {
        let s = filter_with(kind, p, precond_mul(p, r));
        work[wi(W_R, p)] = vec4<f32>(r, dot3(r, s));
        work[wi(W_S, p)] = vec4<f32>(s, kind);
    }
    work[wi(W_C, p)] = vec4<f32>(0.0);
    work[wi(W_Q, p)] = vec4<f32>(0.0);
}

// cg_init of particle p through the adjacency lists.
fn cg_init_item(p: u32, coarse: bool) {
    cg_init_end(p, work[wi(W_DV, p)], apply_a(W_DV, p), coarse);
}

// c = s + β c and q = S (A s) + β q for particle p, whose s (with its
// filter kind in w) is `s` and (A s)_p, unfiltered, `as_p`, with cᵀq's
// term in q's w (twin: the particle loop of cpu::cg::apply).
fn cg_apply_end(p: u32, s: vec4<f32>, as_p: vec3<f32>, beta: f32) {
    let t = filter_with(s.w, p, as_p);
    let c = s.xyz + work[wi(W_C, p)].xyz * beta;
    let q = t + work[wi(W_Q, p)].xyz * beta;
    work[wi(W_C, p)] = vec4<f32>(c, 0.0);
    work[wi(W_Q, p)] = vec4<f32>(q, dot3(c, q));
}

// cg_apply of particle p through the adjacency lists.
fn cg_apply_item(p: u32, beta: f32) {
    cg_apply_end(p, work[wi(W_S, p)], apply_a(W_S, p), beta);
}

// Δv of particle p after the step `alpha` along c (stored) and r after
// it (returned, with the particle's filter kind in w: the caller stores r
// with its term of ρ). The `first` update (after cg_init) only
// preconditions the initial residual.
fn update_particle(p: u32, alpha: f32, first: bool) -> vec4<f32> {
    var r = work[wi(W_R, p)].xyz;
    if (first) {
        return vec4<f32>(r, filter_kind(p));
    }
    let dv = work[wi(W_DV, p)];
    let dv_new = dv.xyz + work[wi(W_C, p)].xyz * alpha;
    r -= work[wi(W_Q, p)].xyz * alpha;
    work[wi(W_DV, p)] = vec4<f32>(dv_new, dv.w);
    return vec4<f32>(r, dv.w);
}

// The CG update of particle p without coarse levels (twin: the particle
// loop of cpu::cg::update): Δv and r (update_particle), s = S P r with
// the filter kind in its w, ρ's term r·P r in r's w.
fn cg_update_item(p: u32, alpha: f32, first: bool) {
    let rk = update_particle(p, alpha, first);
    let r = rk.xyz;
    let s = precond_mul(p, r);
    work[wi(W_R, p)] = vec4<f32>(r, dot3(r, s));
    work[wi(W_S, p)] = vec4<f32>(filter_with(rk.w, p, s), rk.w);
}

// The CG iterations' indirect dispatch arguments (group 1): a slot
// (workgroups, 1, 1) per recorded CG iteration, and one more, for each
// indirect dispatch of an iteration. `alpha_args` holds cg_alpha's slots,
// then cg_apply's, then cg_prolong's (the pass before the iteration's
// cg_apply); `beta_args` cg_beta's, then cg_update's. An iteration's slots
// hold workgroups only while it is due: cg_start enables iteration 0's
// `alpha_args` slots, cg_alpha k enables iteration k's `beta_args` slots
// and clears k − 1's, cg_beta k clears k's `alpha_args` slots and enables
// k + 1's — so once CG stops, the rest of the recorded iterations dispatch
// no workgroup at all (an empty indirect dispatch costs far less than a
// workgroup that runs only to find CG stopped). A kernel may not bind the
// buffer it is dispatched from: cg_alpha binds only `beta_args`, cg_beta
// only `alpha_args`, cg_start both (with group 0's six, the eight storage
// buffers every WebGPU device grants).
@group(1) @binding(0) var<storage, read_write> alpha_args: array<u32>;
@group(1) @binding(1) var<storage, read_write> beta_args: array<u32>;

// cg_apply's workgroups: it gathers by block on a grid (params.grid.w
// blocks).
fn apply_groups() -> u32 {
    if (GRID) {
        return (params.grid.w + WORKGROUP - 1u) / WORKGROUP;
    }
    return params.partial_count;
}

// cg_update's and cg_prolong's workgroups: with coarse levels they take a
// level-1 aggregate per invocation.
fn update_groups() -> u32 {
    if (COARSE) {
        return (params.coarse.z + WORKGROUP - 1u) / WORKGROUP;
    }
    return params.partial_count;
}

// Slots per dispatch in `alpha_args` (three dispatches of three words).
fn alpha_arg_slots() -> u32 {
    return arrayLength(&alpha_args) / 9u;
}

// Enables (`on`) or clears iteration k's slots of `alpha_args`.
fn set_alpha_args(k: u32, on: bool) {
    let slots = alpha_arg_slots();
    alpha_args[3u * k] = select(0u, 1u, on);
    alpha_args[3u * (slots + k)] = select(0u, apply_groups(), on);
    alpha_args[3u * (2u * slots + k)] = select(0u, update_groups(), on);
}

// Enables (`on`) or clears iteration k's slots of `beta_args`.
fn set_beta_args(k: u32, on: bool) {
    let slots = arrayLength(&beta_args) / 6u;
    beta_args[3u * k] = select(0u, 1u, on);
    beta_args[3u * (slots + k)] = select(0u, update_groups(), on);
}

// The CG iteration in progress (counted by cg_beta).
fn cg_iteration() -> u32 {
    return atomicLoad(&status[sw(STATUS_CG_ITERATIONS)]);
}

// cg_start: clear the slots the last solve left enabled, then enable
// iteration 0's `alpha_args` slots if CG runs.
fn start_slots(running: bool) {
    set_alpha_args(atomicLoad(&status[sw(STATUS_ALPHA_SLOT)]), false);
    set_beta_args(atomicLoad(&status[sw(STATUS_BETA_SLOT)]), false);
    if (running) {
        set_alpha_args(0u, true);
        atomicStore(&status[sw(STATUS_ALPHA_SLOT)], 0u);
    }
}

// cg_alpha of iteration k: clear iteration k − 1's `beta_args` slots;
// enable k's unless CG stopped.
fn alpha_slots_next(k: u32, running: bool) {
    if (k > 0u) {
        set_beta_args(k - 1u, false);
    }
    if (running) {
        set_beta_args(k, true);
        atomicStore(&status[sw(STATUS_BETA_SLOT)], k);
    }
}

// cg_beta of iteration k: clear iteration k's `alpha_args` slots; enable
// k + 1's unless CG stopped (the slots after the last recorded iteration
// launch only its cg_prolong).
fn beta_slots_next(k: u32, running: bool) {
    set_alpha_args(k, false);
    if (running && k + 1u < alpha_arg_slots()) {
        set_alpha_args(k + 1u, true);
        atomicStore(&status[sw(STATUS_ALPHA_SLOT)], k + 1u);
    }
}

var<workgroup> scratch: array<f32, WORKGROUP>;
var<workgroup> shared_flag: u32;

// Twin: cpu::cg::block_partials inside one block: writes this workgroup's sum
// of `value`, in invocation order, to partials[slot]. Every invocation of
// the workgroup must call it. Two barriers and one invocation adding up:
// on lavapipe a barrier costs more than the additions of a whole tree.
fn reduce_to_partial(value: f32, lid: u32, wid: u32, slot: u32) {
    // Invocation 0 may still be reading the previous reduction's values.
    workgroupBarrier();
    scratch[lid] = value;
    workgroupBarrier();
    if (lid == 0u) {
        let count = min(WORKGROUP, params.particle_count - wid * WORKGROUP);
        var total = 0.0;
        for (var k = 0u; k < count; k++) {
            total += scratch[k];
        }
        set_partial(pi(slot, wid), total);
    }
}

// Sum of the partials of `slot`, in sequence (twin: the block loop of
// block_sum).
fn sum_partials(slot: u32) -> f32 {
    var total = 0.0;
    for (var k = 0u; k < params.partial_count; k++) {
        total += partial(pi(slot, k));
    }
    return total;
}

// Where sum_staged finds its values.
const STAGED_PARTIALS: u32 = 0u;
const STAGED_LEVEL2: u32 = 1u;

// Value k of a staged sum: partial k of `slot`, or the term in the w of
// level-2 aggregate k's W_COARSE_Z (see cg_coarse).
fn staged_value(source: u32, slot: u32, k: u32) -> f32 {
    if (source == STAGED_LEVEL2) {
        return work[wa(W_COARSE_Z, params.coarse.z + k)].w;
    }
    return partial(pi(slot, k));
}

var<workgroup> stage: array<f32, SUM_GROUP>;

// Σ of the `count` values of `source` in sequence (twin: the block loop of
// block_sum; the level-2 loop of Coarse::level2): the workgroup copies
// SUM_GROUP values at a time into workgroup memory, and invocation 0 adds
// them from there. On a GPU, invocation 0 loading each value from storage
// itself would wait out a memory latency every few values (a 257² cloth
// has ~1000 block sums; see gpu::kernels::sum_group for why every
// adapter runs this form). The result is valid in invocation 0 only.
// Call from uniform control flow, after a storageBarrier.
fn sum_staged(source: u32, slot: u32, count: u32, lid: u32) -> f32 {
    var total = 0.0;
    for (var base = 0u; base < count; base += SUM_GROUP) {
        if (base + lid < count) {
            stage[lid] = staged_value(source, slot, base + lid);
        }
        workgroupBarrier();
        if (lid == 0u) {
            for (var k = 0u; k < min(SUM_GROUP, count - base); k++) {
                total += stage[k];
            }
        }
        workgroupBarrier();
    }
    return total;
}

// Σ_p work[wi(sec, p)].w in block_sum's order, by one workgroup of
// SUM_GROUP invocations: invocation l adds up blocks l, l + SUM_GROUP, …
// of WORKGROUP particles into partials[slot], then the block sums are
// added in sequence (sum_staged); the total is valid in invocation 0
// only. The per-particle kernels leave their dot-product terms in the w
// of a vector they write anyway, so they need no workgroup barrier. Call
// from uniform control flow.
fn sum_w(sec: u32, slot: u32, lid: u32) -> f32 {
    for (var b = lid; b < params.partial_count; b += SUM_GROUP) {
        let start = params.particle_base + b * WORKGROUP;
        let end = min(start + WORKGROUP, params.particle_base + params.particle_count);
        var block = 0.0;
        for (var p = start; p < end; p++) {
            block += work[wi(sec, p)].w;
        }
        set_partial(pi(slot, b), block);
    }
    storageBarrier();
    return sum_staged(STAGED_PARTIALS, slot, params.partial_count, lid);
}

// CG scalars C_*, after the partials: δ0, δ (current rᵀM⁻¹r: with the
// coarse levels more than ρ = rᵀP⁻¹r with the block-Jacobi P alone, which
// decides convergence and is summed where it is tested), α, β.
fn scalar_index(k: u32) -> u32 {
    return params.partial_base + P_SLOTS * params.partial_count + k;
}

// α = δ / cᵀq, cᵀq summed from the w of W_Q (twin: cpu::cg::alpha). A
// cᵀq that is not positive means c vanished to rounding: CG stops.
// Invocation 0 stores α or the stop and returns whether CG goes on (the
// others return false). Call from uniform control flow.
fn cg_alpha_scalar(lid: u32) -> bool {
    let cq = sum_w(W_Q, P_CQ, lid);
    if (lid != 0u) {
        return false;
    }
    let running = finite1(cq) && cq > 0.0;
    if (running) {
        set_partial(scalar_index(C_ALPHA), partial(scalar_index(C_DELTA)) / cq);
    } else {
        atomicStore(&status[sw(STATUS_CG_STOPPED)], 1u);
    }
    return running;
}

// Whether CG has stopped (converged or broken down; set by the one-group
// kernels cg_start, cg_alpha and cg_beta), uniform over the workgroup (for
// those kernels, which have barriers after it).
fn cg_stopped(lid: u32) -> bool {
    if (lid == 0u) {
        shared_flag = atomicLoad(&status[sw(STATUS_CG_STOPPED)]);
    }
    return workgroupUniformLoad(&shared_flag) != 0u;
}

// Whether CG has stopped, for a per-particle kernel (no barrier).
fn cg_done() -> bool {
    return atomicLoad(&status[sw(STATUS_CG_STOPPED)]) != 0u;
}
