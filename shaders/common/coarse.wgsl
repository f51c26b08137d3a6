// The implicit CG's coarse levels on a grid cloth or a world of grid
// cloths (twin: cpu::coarse):
// each aggregate (common/coarse_layout.wgsl) with the inverse of its 3×3
// Galerkin diagonal block D, added to the block-Jacobi preconditioner.
// cg_update takes a slot of the level-2-major order of the level-1
// aggregates per invocation (cg_update_slot), so that a workgroup holds
// whole level-2 aggregates and sums their residuals in its own tree.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/coarse_layout.wgsl"
#include "common/cg.wgsl"

fn coarse_inverse(k: u32) -> Sym3 {
    return Sym3(work[wa(W_COARSE_INV_D, k)].xyz, work[wa(W_COARSE_INV_O, k)].xyz);
}

// Aggregate k's θ D⁻¹ (both levels, level 1's first), D summed from its
// particles' contributions left by prepare_particle, or zero where D is
// not invertible (twin: cpu::coarse::Coarse::setup).
fn coarse_setup_item(k: u32) {
    let n1 = params.coarse.z;
    var side = LEVEL1_SIDE;
    var sec_d = W_LEVEL1_D;
    var sec_o = W_LEVEL1_O;
    var pc = coarse_piece_at(3u, k);
    var index = k - pc.level1;
    if (k >= n1) {
        side = LEVEL2_SIDE;
        sec_d = W_LEVEL2_D;
        sec_o = W_LEVEL2_O;
        pc = coarse_piece_at(4u, k - n1);
        index = k - n1 - pc.level2;
    }
    let nx = pc.nx;
    let across = piece_across(pc, side);
    let row0 = (index / across) * side;
    let col0 = (index % across) * side;
    var d = vec3<f32>(0.0);
    var o = vec3<f32>(0.0);
    var mass = 0.0;
    var trace = 0.0;
    for (var row = row0; row < min(row0 + side, pc.ny); row++) {
        for (var col = col0; col < min(col0 + side, nx); col++) {
            let p = params.particle_base + pc.first + row * nx + col;
            d += work[wi(sec_d, p)].xyz;
            o += work[wi(sec_o, p)].xyz;
            mass += v[p].w;
            trace += work[wi(W_LEVEL1_O, p)].w;
        }
    }
    let inv = sym3_inverse(Sym3(d, o));
    var theta = 0.0;
    if (trace > 0.0) {
        theta = 1.0 - 3.0 * mass / trace;
    }
    var m = Sym3(vec3<f32>(0.0), vec3<f32>(0.0));
    if (inv.ok) {
        m = Sym3(inv.m.d * theta, inv.m.o * theta);
    }
    work[wa(W_COARSE_INV_D, k)] = vec4<f32>(m.d, 0.0);
    work[wa(W_COARSE_INV_O, k)] = vec4<f32>(m.o, 0.0);
}

// A particle's contributions to its aggregates' D at both levels (twin:
// `levels` in cpu::implicit::prepare): its mass times I plus the blocks of
// its springs whose other end lies in another aggregate of that level.
struct Levels {
    own: vec2<u32>,
    d1: Sym3,
    d2: Sym3,
}

fn levels_start(p: u32, m: f32, coarse: bool) -> Levels {
    let diag = Sym3(vec3<f32>(m), vec3<f32>(0.0));
    if (!coarse) {
        return Levels(vec2<u32>(0u), diag, diag);
    }
    return Levels(vec2<u32>(coarse_of(LEVEL1_SIDE, p), coarse_of(LEVEL2_SIDE, p)), diag, diag);
}

// `l` plus the block `blk` of a spring whose other end is `other`.
fn levels_add(l: Levels, other: u32, blk: vec4<f32>, coarse: bool) -> Levels {
    if (!coarse) {
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

// Particle p's contributions `levels` and the trace of its block-Jacobi
// block `trace` [kg] (for θ), for coarse_setup (twin: Coarse::contrib and
// Coarse::trace).
fn store_levels(p: u32, levels: Levels, trace: f32) {
    work[wi(W_LEVEL1_D, p)] = vec4<f32>(levels.d1.d, 0.0);
    work[wi(W_LEVEL1_O, p)] = vec4<f32>(levels.d1.o, trace);
    work[wi(W_LEVEL2_D, p)] = vec4<f32>(levels.d2.d, 0.0);
    work[wi(W_LEVEL2_O, p)] = vec4<f32>(levels.d2.o, 0.0);
}

// What cg_update_aggregate found of a level-1 aggregate: Πᵀr, its term
// of δ and the sum of its particles' terms of ρ (row-major, in sequence).
struct Level1 {
    r1: vec3<f32>,
    term1: f32,
    rho: f32,
}

// The CG update of level-1 aggregate `a`'s particles (row-major; twin:
// the particle loop of cpu::cg::update, then Coarse::level1): each
// particle's Δv, r and ρ's term (update_particle), then s = S P r plus
// the aggregate's correction S D⁻¹Πᵀr; Πᵀr and its term of δ into its
// W_COARSE_Z.
fn cg_update_aggregate(a: u32, alpha: f32, first: bool) -> Level1 {
    // P r and the filter kind of each particle, until the correction is
    // known (in registers: the loops unroll).
    var pr: array<vec4<f32>, LEVEL1_SIDE * LEVEL1_SIDE>;
    var r1 = vec3<f32>(0.0);
    var rho = 0.0;
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let rk = update_particle(p, alpha, first);
            let r = rk.xyz;
            let s = precond_mul(p, r);
            let term = dot3(r, s);
            work[wi(W_R, p)] = vec4<f32>(r, term);
            rho += term;
            pr[k] = vec4<f32>(s, rk.w);
            r1 += r;
        }
    }
    let z = sym3_mul(coarse_inverse(a), r1);
    let term1 = dot3(r1, z);
    work[wa(W_COARSE_Z, a)] = vec4<f32>(r1, term1);
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let kind = pr[k].w;
            let s = filter_with(kind, p, pr[k].xyz) + filter_with(kind, p, z);
            work[wi(W_S, p)] = vec4<f32>(s, kind);
        }
    }
    return Level1(r1, term1, rho);
}

// Level-2 aggregate b's correction and term from its level-2 residual r2
// into its W_COARSE_Z; returns the term (twin: Coarse::level2).
fn level2_store(b: u32, r2: vec3<f32>) -> f32 {
    let k = params.coarse.z + b;
    let z = sym3_mul(coarse_inverse(k), r2);
    let term = dot3(r2, z);
    work[wa(W_COARSE_Z, k)] = vec4<f32>(z, term);
    return term;
}

// cg_update of slot `slot` of the level-2-major order, `running` if CG
// goes on (twin: Coarse::level1, level2 and partials): its level-1
// aggregate's update (cg_update_aggregate), the level-2 residual summed
// over the slots of its level-2 aggregate by the workgroup's tree, the
// level-2 correction and term stored by the aggregate's first slot.
// Returns the slot's terms (ρ, δ's coarse terms) for the workgroup's
// partial sums. Call from uniform control flow, every invocation (lane
// `lid`).
fn cg_update_slot(slot: u32, lid: u32, alpha: f32, first: bool, running: bool) -> vec2<f32> {
    let a = level1_of_slot(slot);
    var l1 = Level1(vec3<f32>(0.0), 0.0, 0.0);
    if (running && a != NO_PARTICLE) {
        l1 = cg_update_aggregate(a, alpha, first);
    }
    // A level-2 aggregate's slots are a run of the tree.
    let r2 = tree_run_sums(vec4<f32>(l1.r1, 0.0), lid).xyz;
    var dc = l1.term1;
    if (running && slot % LEVEL2_SLOTS == 0u && slot < coarse_slots()) {
        dc = l1.term1 + level2_store(slot / LEVEL2_SLOTS, r2);
    }
    return vec2<f32>(l1.rho, dc);
}

// s += S z of level-1 aggregate `a`'s level-2 aggregate's correction,
// particle by particle (twin: Coarse::prolong): the workgroup kernels'
// pass before each cg_apply (the multi-dispatch cg_apply adds it as it
// loads s, cg_source); s keeps the filter kind in its w.
fn cg_prolong_item(a: u32) {
    let z = work[wa(W_COARSE_Z, coarse_of(LEVEL2_SIDE, level1_particle(a, 0u)))].xyz;
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let s = work[wi(W_S, p)];
            work[wi(W_S, p)] = vec4<f32>(s.xyz + filter_with(s.w, p, z), s.w);
        }
    }
}

// The level-2 corrections z (W_COARSE_Z's xyz) within reach of one grid
// block, for cg_apply, which adds S z to each s it loads. A block's
// stencil spans its rows and columns and GRID_REACH more each way, fewer
// than LEVEL2_SIDE (the assertion beside gpu::grid::REACH),
// so at most two level-2 aggregates each way: `first` is the (row,
// column) of the top-left one and zij the correction i rows and j columns
// from it. Loaded once per block, picked per stencil point.
struct Near {
    first: vec2<i32>,
    z00: vec3<f32>,
    z01: vec3<f32>,
    z10: vec3<f32>,
    z11: vec3<f32>,
}

var<private> near: Near;

// Grid springs join particles up to this many rows or columns apart
// (twin: gpu::grid::REACH).
const GRID_REACH: i32 = 2;

fn level2_correction(at: vec2<i32>) -> vec3<f32> {
    return work[wa(W_COARSE_Z, coarse_index(LEVEL2_SIDE, vec2<u32>(at)))].xyz;
}

// Loads the corrections near the block whose first particle is at `o`
// (row, column) and whose size is `size` (rows, columns).
fn near_load(o: vec2<i32>, size: vec2<i32>) {
    let side = i32(LEVEL2_SIDE);
    let last = vec2<i32>(i32(params.coarse.y), i32(params.coarse.x)) - 1;
    let lo = max(o - GRID_REACH, vec2<i32>(0)) / side;
    let hi = min(o + size - 1 + GRID_REACH, last) / side;
    near = Near(
        lo,
        level2_correction(lo),
        level2_correction(vec2<i32>(lo.x, hi.y)),
        level2_correction(vec2<i32>(hi.x, lo.y)),
        level2_correction(hi),
    );
}

// The level-2 correction of the particle at `rc` (row, column), which is
// within reach of the block of the last near_load.
fn near_correction(rc: vec2<i32>) -> vec3<f32> {
    let d = rc / i32(LEVEL2_SIDE) - near.first;
    let top = select(near.z00, near.z01, d.y != 0);
    let bottom = select(near.z10, near.z11, d.y != 0);
    return select(top, bottom, d.x != 0);
}
