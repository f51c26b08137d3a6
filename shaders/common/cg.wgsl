// Shared by the CG kernels (implicit integrator and the scalable
// semi-implicit filter). Twins: cpu::cg, cpu::implicit and cpu::mat3.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/coarse_layout.wgsl"

// Twin: implicit::Filter::apply. `f` is W_Z's w (kind), `n` W_FILTER's xyz.
fn filter_apply(kind: f32, n: vec3<f32>, a: vec3<f32>) -> vec3<f32> {
    if (!has_filter()) {
        return a;
    }
    if (kind == FILTER_FIXED) {
        return vec3<f32>(0.0);
    }
    // Only colliders make plane and held filters (lavapipe runs a branch no lane
    // takes, so it is compiled out without them).
    if (has_ground() || has_spheres()) {
        if (kind == FILTER_PLANE) {
            return a - n * dot3(a, n);
        }
        if (kind == FILTER_HELD) {
            return vec3<f32>(0.0);
        }
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
    var own = work[wi(sec, p)].xyz;
    if (!GRID && coarse_at_load() && sec == W_S) {
        own = cg_source(p).xyz;
    }
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
        let q = topo(others + k);
        var other = work[wi(sec, q)].xyz;
        if (coarse_at_load() && sec == W_S) {
            other = cg_source(q).xyz;
        }
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
// ρ's terms); a zero previous direction and product. Returns the
// particle's terms of δ0 (kept in W_RHS's w) and ρ.
fn cg_init_end(p: u32, dv: vec4<f32>, adv: vec3<f32>, coarse: bool) -> vec2<f32> {
    let kind = dv.w;
    let q = filter_with(kind, p, adv);
    let rhs = work[wi(W_RHS, p)];
    let r = filter_with(kind, p, rhs.xyz) - q;
    var rho = 0.0;
    if (coarse) {
        work[wi(W_R, p)] = vec4<f32>(r, 0.0);
    } else {
        let s = filter_with(kind, p, precond_mul(p, r));
        rho = dot3(r, s);
        work[wi(W_R, p)] = vec4<f32>(r, rho);
        work[wi(W_S, p)] = vec4<f32>(s, kind);
    }
    work[wi(W_C, p)] = vec4<f32>(0.0);
    work[wi(W_Q, p)] = vec4<f32>(0.0);
    return vec2<f32>(rhs.w, rho);
}

// cg_init of particle p through the adjacency lists.
fn cg_init_item(p: u32, coarse: bool) -> vec2<f32> {
    return cg_init_end(p, work[wi(W_DV, p)], apply_a(W_DV, p), coarse);
}

// c = s + β c and q = S (A s) + β q for particle p, whose s (with its
// filter kind in w) is `s` and (A s)_p, unfiltered, `as_p`, with cᵀq's
// term in q's w, which it returns (twin: the particle loop of
// cpu::cg::apply).
fn cg_apply_end(p: u32, s: vec4<f32>, as_p: vec3<f32>, beta: f32) -> f32 {
    let t = filter_with(s.w, p, as_p);
    let c = s.xyz + work[wi(W_C, p)].xyz * beta;
    let q = t + work[wi(W_Q, p)].xyz * beta;
    let cq = dot3(c, q);
    work[wi(W_C, p)] = vec4<f32>(c, 0.0);
    work[wi(W_Q, p)] = vec4<f32>(q, cq);
    return cq;
}

// cg_apply of particle p through the adjacency lists.
fn cg_apply_item(p: u32, beta: f32) -> f32 {
    return cg_apply_end(p, cg_source(p), apply_a(W_S, p), beta);
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
// the filter kind in its w, ρ's term r·P r in r's w, which it returns.
fn cg_update_item(p: u32, alpha: f32, first: bool) -> f32 {
    let rk = update_particle(p, alpha, first);
    let r = rk.xyz;
    let s = precond_mul(p, r);
    let rho = dot3(r, s);
    work[wi(W_R, p)] = vec4<f32>(r, rho);
    work[wi(W_S, p)] = vec4<f32>(filter_with(rk.w, p, s), rk.w);
    return rho;
}

// Whether cg_apply adds the level-2 corrections to the s it loads: with
// coarse levels, on the multi-dispatch path (a workgroup kernel, whose
// pipeline may have COARSE set for a batch's other cloths, adds them to
// the stored s in a pass of its own).
fn coarse_at_load() -> bool {
    return COARSE && !CLOTH_TABLE;
}

// The s cg_apply takes at particle p, with its filter kind in w: as
// cg_update stored it, plus with coarse levels (multi-dispatch) the
// correction S z of its level-2 aggregate (twin: cpu::cg::prolong; on a
// grid the gather adds it through near_correction instead). The workgroup
// kernels add the correction to the stored s in a pass of their own.
fn cg_source(p: u32) -> vec4<f32> {
    let s = work[wi(W_S, p)];
    if (!coarse_at_load()) {
        return s;
    }
    return vec4<f32>(s.xyz + filter_with(s.w, p, level2_z(p)), s.w);
}

// The CG iterations' indirect dispatch arguments (group 1): a slot
// (workgroups, 1, 1) per recorded CG iteration, and one more, of each
// per-iteration kernel: `apply_args` cg_apply's, `update_args`
// cg_update's. A slot holds workgroups only while its iteration is due:
// cg_init enables iteration 0's cg_apply, cg_apply k enables iteration
// k's cg_update (unless CG has converged) and clears k − 1's, cg_update k
// clears its iteration's cg_apply and enables k + 1's (unless CG broke
// down) — so once CG stops, the rest of the recorded iterations dispatch
// no workgroup at all (an empty indirect dispatch costs far less than a
// workgroup that runs only to find CG stopped). A kernel may not bind the
// buffer it is dispatched from: cg_apply binds only `update_args`,
// cg_update only `apply_args`, cg_init both (with group 0's six, the
// eight storage buffers every WebGPU device grants).
@group(1) @binding(0) var<storage, read_write> apply_args: array<u32>;
@group(1) @binding(1) var<storage, read_write> update_args: array<u32>;

// cg_init's and cg_apply's workgroups of CG_GROUP, a particle per
// invocation (the CG kernels gather no blocks, so that a workgroup's
// partial sums always cover the same particles), and CG's reduction
// blocks.
fn cg_blocks() -> u32 {
    return (params.particle_count + CG_GROUP - 1u) / CG_GROUP;
}

// cg_update's workgroups: with coarse levels it takes a slot of the
// level-2-major order of the level-1 aggregates per invocation.
fn update_groups() -> u32 {
    if (COARSE) {
        return coarse_slot_partials();
    }
    return cg_blocks();
}

// Slots of the level-2-major order of the level-1 aggregates (twin:
// Aggregation::slots): LEVEL2_SLOTS per level-2 aggregate.
const LEVEL2_SLOTS: u32 = 16u;

fn coarse_slots() -> u32 {
    return params.coarse.w * LEVEL2_SLOTS;
}

// Partial sums of the per-slot cg_update: one per workgroup.
fn coarse_slot_partials() -> u32 {
    return (coarse_slots() + CG_GROUP - 1u) / CG_GROUP;
}

// Enables (`on`) or clears iteration k's cg_apply slot.
fn set_apply_args(k: u32, on: bool) {
    apply_args[3u * k] = select(0u, cg_blocks(), on);
}

// Enables (`on`) or clears iteration k's cg_update slot.
fn set_update_args(k: u32, on: bool) {
    update_args[3u * k] = select(0u, update_groups(), on);
}

// cg_init, once per solve (one invocation): clear the slots the last
// solve left enabled, enable iteration 0's cg_apply, and zero the count
// and the stop.
fn start_slots() {
    set_apply_args(atomicLoad(&status[sw(STATUS_APPLY_SLOT)]), false);
    set_update_args(atomicLoad(&status[sw(STATUS_UPDATE_SLOT)]), false);
    set_apply_args(0u, true);
    atomicStore(&status[sw(STATUS_APPLY_SLOT)], 0u);
    atomicStore(&status[sw(STATUS_CG_ITERATIONS)], 0u);
    atomicStore(&status[sw(STATUS_CG_STOPPED)], 0u);
}

// cg_apply of iteration k (one invocation): its scalars for cg_update
// and the host, then clear iteration k − 1's cg_update slot and enable
// k's, or stop CG.
fn apply_slots(k: u32, running: bool, delta0: f32, delta: f32, beta: f32) {
    if (k == 0u) {
        set_partial(scalar_index(C_DELTA0), delta0);
    } else {
        set_update_args(k - 1u, false);
    }
    set_partial(scalar_index(C_DELTA), delta);
    set_partial(scalar_index(C_BETA), beta);
    if (running) {
        set_update_args(k, true);
        atomicStore(&status[sw(STATUS_UPDATE_SLOT)], k);
    } else {
        atomicStore(&status[sw(STATUS_CG_STOPPED)], 1u);
    }
}

// cg_update of iteration k (one invocation): α for the host, clear the
// iteration's cg_apply slot; then count the iteration, keep δ for the
// next β and enable k + 1's cg_apply (the slot after the last recorded
// iteration launches nothing), or stop CG.
fn update_slots(k: u32, running: bool, alpha: f32, delta: f32) {
    set_partial(scalar_index(C_ALPHA), alpha);
    set_apply_args(k, false);
    if (running) {
        atomicStore(&status[sw(STATUS_CG_ITERATIONS)], k + 1u);
        set_partial(scalar_index(C_DELTA_PREV), delta);
        if (k + 1u < arrayLength(&apply_args) / 3u) {
            set_apply_args(k + 1u, true);
            atomicStore(&status[sw(STATUS_APPLY_SLOT)], k + 1u);
        }
    } else {
        atomicStore(&status[sw(STATUS_CG_STOPPED)], 1u);
    }
}

// The reduction tree of a workgroup: one vec4 per lane of CG_GROUP (a
// workgroup kernel's further invocations take no part), then one per run
// of TREE_RUN lanes.
var<workgroup> tree: array<vec4<f32>, CG_GROUP>;
var<workgroup> tree_runs: array<vec4<f32>, CG_GROUP / TREE_RUN>;
var<workgroup> tree_total: vec4<f32>;

// Lanes per run of the tree that one invocation adds up in registers.
const TREE_RUN: u32 = 16u;

// The pairwise sum of TREE_RUN values `v`: v[i] += v[i + w] for w = 1, 2,
// 4, 8 at each i that is a multiple of 2w (twin: cpu::cg::pairwise).
fn pairwise_run(values: array<vec4<f32>, TREE_RUN>) -> vec4<f32> {
    var v = values;
    for (var w = 1u; w < TREE_RUN; w *= 2u) {
        for (var i = 0u; i < TREE_RUN; i += 2u * w) {
            v[i] = v[i] + v[i + w];
        }
    }
    return v[0];
}

// The pairwise sum of `tree`'s run of TREE_RUN lanes from lane `first`.
fn tree_run(first: u32) -> vec4<f32> {
    var v: array<vec4<f32>, TREE_RUN>;
    for (var k = 0u; k < TREE_RUN; k++) {
        v[k] = tree[first + k];
    }
    return pairwise_run(v);
}

// Writes the lanes' `value`s into `tree` (lane l at l). Call from uniform
// control flow, every invocation.
fn tree_store(value: vec4<f32>, lid: u32) {
    // An earlier tree's readers are done with it.
    workgroupBarrier();
    if (lid < CG_GROUP) {
        tree[lid] = value;
    }
    workgroupBarrier();
}

// The sum of each run of TREE_RUN lanes' `value`s, valid in the run's first
// lane: the run's part of the pairwise tree. Call from uniform control
// flow, every invocation.
fn tree_run_sums(value: vec4<f32>, lid: u32) -> vec4<f32> {
    tree_store(value, lid);
    if (lid < CG_GROUP && lid % TREE_RUN == 0u) {
        return tree_run(lid);
    }
    return vec4<f32>(0.0);
}

// The pairwise tree's total of the CG_GROUP lanes' `value`s (lane i +=
// lane i + w for w = 1, 2, 4, … at each i that is a multiple of 2w; twin:
// cpu::cg::pairwise), uniform over the workgroup: each run of TREE_RUN
// lanes is summed by one invocation in registers, then the runs' sums by
// one more — the same additions as a level per barrier, in four barriers.
// Call from uniform control flow, every invocation.
fn tree_reduce(value: vec4<f32>, lid: u32) -> vec4<f32> {
    tree_store(value, lid);
    if (lid < CG_GROUP / TREE_RUN) {
        tree_runs[lid] = tree_run(lid * TREE_RUN);
    }
    workgroupBarrier();
    if (lid == 0u) {
        var v: array<vec4<f32>, TREE_RUN>;
        for (var k = 0u; k < CG_GROUP / TREE_RUN; k++) {
            v[k] = tree_runs[k];
        }
        tree_total = pairwise_run(v);
    }
    return workgroupUniformLoad(&tree_total);
}

// This workgroup's (`wid`) tree sums of its lanes' `value`s into the
// components of its partials of CG slot `slot` (P_CQ or P_RES) that
// `mask` selects, if `on` (twin: cpu::cg::block_partials). Call from
// uniform control flow, every invocation.
fn write_partials(value: vec4<f32>, lid: u32, wid: u32, slot: u32, mask: vec4<bool>, on: bool) {
    let total = tree_reduce(value, lid);
    if (lid != 0u || !on) {
        return;
    }
    set_cg_partials(slot, wid, total, mask);
}

// Stores the components of `value` that `mask` selects into block b's
// partials of CG slot `slot`.
fn set_cg_partials(slot: u32, b: u32, value: vec4<f32>, mask: vec4<bool>) {
    let i = pi(slot, b);
    work[i] = select(work[i], value, mask);
}

// The partial sums of four CG blocks at once, the workgroup kernels'
// form of write_partials: component c of lane l's `values` is its term of
// block 4 q + c (its particle l there); each component's tree goes to
// component `component` of that block's partials of CG slot `slot`. The
// same tree as each block's own workgroup's. Call from uniform control
// flow, every invocation.
fn write_block_partials(values: vec4<f32>, lid: u32, q: u32, slot: u32, component: u32) {
    let total = tree_reduce(values, lid);
    if (lid != 0u) {
        return;
    }
    for (var c = 0u; c < 4u; c++) {
        let b = 4u * q + c;
        if (b < cg_blocks()) {
            var mask = vec4<bool>(false);
            mask[component] = true;
            set_cg_partials(slot, b, vec4<f32>(total[c]), mask);
        }
    }
}

// The totals of the components of CG slot `slot`'s partials (`counts`
// blocks of each; 0 for a component not wanted), as every workgroup of a
// CG kernel finds them (twin: cpu::cg::sum_partials): lane l adds blocks
// l, l + CG_GROUP, … from zero, then the pairwise tree of the lanes.
// Uniform over the workgroup. Call from uniform control flow, every
// invocation.
fn sum_partials_tree(slot: u32, counts: vec4<u32>, lid: u32) -> vec4<f32> {
    var acc = vec4<f32>(0.0);
    if (lid < CG_GROUP) {
        let most = max(max(counts.x, counts.y), max(counts.z, counts.w));
        for (var k = lid; k < most; k += CG_GROUP) {
            // Adding zero leaves a sum that started at +0 unchanged.
            acc += select(vec4<f32>(0.0), work[pi(slot, k)], vec4<u32>(k) < counts);
        }
    }
    return tree_reduce(acc, lid);
}

// (ρ, δ, δ0 if `first`, 0) of the current residual from the partials the
// last kernel left (twin: cpu::cg::residual_sums, and δ0 from its block
// sums): with coarse levels ρ's partials are the per-slot update's and δ
// adds their coarse terms. Uniform over the workgroup. Call from uniform
// control flow, every invocation.
fn cg_residual_sums(lid: u32, first: bool, coarse: bool) -> vec4<f32> {
    var rho_count = cg_blocks();
    if (coarse) {
        rho_count = coarse_slot_partials();
    }
    let d0_count = select(0u, cg_blocks(), first);
    let dc_count = select(0u, rho_count, coarse);
    var counts = vec4<u32>(0u);
    counts[P_RS] = rho_count;
    counts[P_DC] = dc_count;
    counts[P_D0] = d0_count;
    let sums = sum_partials_tree(P_RES, counts, lid);
    var delta = sums[P_RS];
    if (coarse) {
        delta = sums[P_RS] + sums[P_DC];
    }
    return vec4<f32>(sums[P_RS], delta, sums[P_D0], 0.0);
}

// CG scalars C_*, after the partials: δ0, δ (the current rᵀM⁻¹r: with the
// coarse levels more than ρ = rᵀP⁻¹r with the block-Jacobi P alone, which
// decides convergence), α, β, and the last iteration's δ for the next β.
// Written by one invocation, for the next kernels and the host.
fn scalar_index(k: u32) -> u32 {
    return params.partial_base + P_SLOTS * params.partial_count + k;
}

// Sum of the partials of `slot`, in sequence (the torque compensation's
// order, cpu::torque).
fn sum_partials(slot: u32) -> f32 {
    var total = 0.0;
    for (var k = 0u; k < params.partial_count; k++) {
        total += partial(pi(slot, k));
    }
    return total;
}

var<workgroup> scratch: array<f32, WORKGROUP>;

// The torque compensation's block sum (twin: cpu::torque's reduce): writes
// this workgroup's sum of `value`, in invocation order, to
// partials[slot]. Every invocation of the workgroup must call it. Two
// barriers and one invocation adding up.
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
