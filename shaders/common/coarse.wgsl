// The implicit CG's coarse levels on a grid cloth (twin: cpu::coarse):
// square aggregates of LEVEL1_SIDE and LEVEL2_SIDE particles a side, each
// with the inverse of its 3×3 Galerkin diagonal block D, added to the
// block-Jacobi preconditioner. params.coarse = (columns, rows, level-1
// aggregates, level-2 aggregates); every aggregate lives at its index
// among both levels (level 1's first) in the W_COARSE_* sections.
// The per-iteration kernels that touch particles (cg_update, cg_prolong)
// take one level-1 aggregate per invocation.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

// Twin: cpu::coarse::LEVEL_SIDES.
const LEVEL1_SIDE: u32 = 4u;
const LEVEL2_SIDE: u32 = 16u;
// Level-1 aggregates per level-2 aggregate side.
const LEVEL_RATIO: u32 = 4u;

// Aggregates per row of a level whose aggregates have `side` particles a
// side (twin: Aggregation::across).
fn coarse_across(side: u32) -> u32 {
    return (params.coarse.x + side - 1u) / side;
}

// Aggregates per column (twin: Aggregation::down).
fn coarse_down(side: u32) -> u32 {
    return (params.coarse.y + side - 1u) / side;
}

// Index, among both levels', of the aggregate in aggregate row and column
// `at` of the level whose aggregates have `side` particles a side.
fn coarse_index(side: u32, at: vec2<u32>) -> u32 {
    let offset = select(0u, params.coarse.z, side == LEVEL2_SIDE);
    return offset + at.x * coarse_across(side) + at.y;
}

// Index of particle p's aggregate of side `side`, among both levels'
// (twin: Aggregation::of).
fn coarse_of(side: u32, p: u32) -> u32 {
    let row = local(p) / params.coarse.x;
    let col = local(p) % params.coarse.x;
    return coarse_index(side, vec2<u32>(row / side, col / side));
}

// Particle k (0 ≤ k < LEVEL1_SIDE², row-major) of level-1 aggregate a,
// or NO_PARTICLE where the grid's edge cuts the aggregate. Loops over k
// with this fixed trip count are unrolled by the compilers.
const NO_PARTICLE: u32 = 0xffffffffu;

fn level1_particle(a: u32, k: u32) -> u32 {
    let nx = params.coarse.x;
    let across = coarse_across(LEVEL1_SIDE);
    let row = (a / across) * LEVEL1_SIDE + k / LEVEL1_SIDE;
    let col = (a % across) * LEVEL1_SIDE + k % LEVEL1_SIDE;
    if (row >= params.coarse.y || col >= nx) {
        return NO_PARTICLE;
    }
    return params.particle_base + row * nx + col;
}

fn coarse_inverse(k: u32) -> Sym3 {
    return Sym3(work[wa(W_COARSE_INV_D, k)].xyz, work[wa(W_COARSE_INV_O, k)].xyz);
}

// δ = rᵀM⁻¹r from ρ = rᵀP⁻¹r: ρ itself without coarse levels, else
// ρ plus their terms (cg_coarse). Call from uniform control flow.
fn cg_delta(rho: f32, lid: u32, coarse: bool) -> f32 {
    if (!coarse) {
        return rho;
    }
    return cg_coarse(rho, lid);
}

// CG's scalars before its first iteration (twin: cpu::cg::start): δ0
// from the w of W_RHS, ρ from the w of W_R and δ = ρ plus the coarse
// terms, in the CPU's order; β = 0; CG stopped if done already.
// Invocation 0 stores them and returns whether CG runs (the others return
// false). Call from uniform control flow.
fn cg_start_scalars(lid: u32, coarse: bool) -> bool {
    let delta0 = sum_w(W_RHS, P_D0, lid);
    let rho = sum_w(W_R, P_RS, lid);
    let delta = cg_delta(rho, lid, coarse);
    if (lid != 0u) {
        return false;
    }
    set_partial(scalar_index(C_DELTA0), delta0);
    set_partial(scalar_index(C_DELTA), delta);
    set_partial(scalar_index(C_BETA), 0.0);
    let running = rho > params.cg_tolerance_sq * delta0;
    if (!running) {
        atomicStore(&status[sw(STATUS_CG_STOPPED)], 1u);
    }
    return running;
}

// What cg_beta_scalars found: whether CG goes on, and the iteration it
// counted (from 0).
struct BetaDone {
    running: bool,
    iteration: u32,
}

// The end of a CG iteration (twin: cpu::cg::beta): ρ summed from the w of
// W_R, δ_new = ρ plus the coarse terms, β = δ_new / δ, the iteration
// counted, and CG stopped once ρ ≤ tol² δ0. Invocation 0 stores them and
// returns what it found (the others: not running). Call from uniform
// control flow.
fn cg_beta_scalars(lid: u32, coarse: bool) -> BetaDone {
    let rho = sum_w(W_R, P_RS, lid);
    let delta = cg_delta(rho, lid, coarse);
    if (lid != 0u) {
        return BetaDone(false, 0u);
    }
    set_partial(scalar_index(C_BETA), delta / partial(scalar_index(C_DELTA)));
    set_partial(scalar_index(C_DELTA), delta);
    let running = rho > params.cg_tolerance_sq * partial(scalar_index(C_DELTA0));
    let iteration = atomicAdd(&status[sw(STATUS_CG_ITERATIONS)], 1u);
    if (!running) {
        atomicStore(&status[sw(STATUS_CG_STOPPED)], 1u);
    }
    return BetaDone(running, iteration);
}

// Aggregate k's θ D⁻¹ (both levels, level 1's first), D summed from its
// particles' contributions left by prepare_particle, or zero where D is
// not invertible (twin: cpu::coarse::Coarse::setup).
fn coarse_setup_item(k: u32) {
    let n1 = params.coarse.z;
    var side = LEVEL1_SIDE;
    var index = k;
    var sec_d = W_LEVEL1_D;
    var sec_o = W_LEVEL1_O;
    if (k >= n1) {
        side = LEVEL2_SIDE;
        index = k - n1;
        sec_d = W_LEVEL2_D;
        sec_o = W_LEVEL2_O;
    }
    let nx = params.coarse.x;
    let across = coarse_across(side);
    let row0 = (index / across) * side;
    let col0 = (index % across) * side;
    var d = vec3<f32>(0.0);
    var o = vec3<f32>(0.0);
    var mass = 0.0;
    var trace = 0.0;
    for (var row = row0; row < min(row0 + side, params.coarse.y); row++) {
        for (var col = col0; col < min(col0 + side, nx); col++) {
            let p = params.particle_base + row * nx + col;
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

// The CG update of level-1 aggregate `a`'s particles (row-major; twin:
// the particle loop of cpu::cg::update, then Coarse::level1): each
// particle's Δv, r and ρ's term (update_particle), then s = S P r plus
// the aggregate's correction S D⁻¹Πᵀr; Πᵀr and its term of δ into its
// W_COARSE_Z.
fn cg_update_aggregate(a: u32, alpha: f32, first: bool) {
    // P r and the filter kind of each particle, until the correction is
    // known (in registers: the loops unroll).
    var pr: array<vec4<f32>, LEVEL1_SIDE * LEVEL1_SIDE>;
    var r1 = vec3<f32>(0.0);
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let rk = update_particle(p, alpha, first);
            let r = rk.xyz;
            let s = precond_mul(p, r);
            work[wi(W_R, p)] = vec4<f32>(r, dot3(r, s));
            pr[k] = vec4<f32>(s, rk.w);
            r1 += r;
        }
    }
    let z = sym3_mul(coarse_inverse(a), r1);
    work[wa(W_COARSE_Z, a)] = vec4<f32>(r1, dot3(r1, z));
    for (var k = 0u; k < LEVEL1_SIDE * LEVEL1_SIDE; k++) {
        let p = level1_particle(a, k);
        if (p != NO_PARTICLE) {
            let kind = pr[k].w;
            let s = filter_with(kind, p, pr[k].xyz) + filter_with(kind, p, z);
            work[wi(W_S, p)] = vec4<f32>(s, kind);
        }
    }
}

// s += S z of level-1 aggregate `a`'s level-2 aggregate's correction,
// particle by particle (twin: Coarse::prolong); s keeps the filter kind
// in its w.
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

// δ = ρ + the coarse terms of rᵀM⁻¹r, after the per-aggregate cg_update
// left each level-1 aggregate's Πᵀr and term in W_COARSE_Z: each level-2
// aggregate's Πᵀr summed from its level-1 aggregates', its correction
// z = D⁻¹Πᵀr into its W_COARSE_Z (twin: Coarse::level2). Invocation l
// takes level-2 aggregates l, l + SUM_GROUP, … and leaves their terms
// (level-1 ones first) in the w of their z, added in sequence by
// sum_staged. `rho` and the result are valid in invocation 0 only (see
// sum_w). Call from uniform control flow.
fn cg_coarse(rho: f32, lid: u32) -> f32 {
    let n1 = params.coarse.z;
    let n2 = params.coarse.w;
    let across1 = coarse_across(LEVEL1_SIDE);
    let down1 = coarse_down(LEVEL1_SIDE);
    let across2 = coarse_across(LEVEL2_SIDE);
    for (var b = lid; b < n2; b += SUM_GROUP) {
        let row2 = b / across2;
        let col2 = b % across2;
        var term = 0.0;
        var r2 = vec3<f32>(0.0);
        for (var row1 = row2 * LEVEL_RATIO; row1 < min((row2 + 1u) * LEVEL_RATIO, down1); row1++) {
            for (var col1 = col2 * LEVEL_RATIO; col1 < min((col2 + 1u) * LEVEL_RATIO, across1); col1++) {
                let level1 = work[wa(W_COARSE_Z, row1 * across1 + col1)];
                term += level1.w;
                r2 += level1.xyz;
            }
        }
        let k = n1 + b;
        let z = sym3_mul(coarse_inverse(k), r2);
        term += dot3(r2, z);
        work[wa(W_COARSE_Z, k)] = vec4<f32>(z, term);
    }
    storageBarrier();
    return rho + sum_staged(STAGED_LEVEL2, 0u, n2, lid);
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
