// CG iteration, part 1: the direction c = s + β c and its product
// q = S A c = S A s + β q (twin: the folded direction update of
// cpu::implicit::step), and cᵀq's term in q's w.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "generated/grid_block.wgsl"

@compute @workgroup_size(WORKGROUP)
fn cg_apply(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (cg_done()) {
        return;
    }
    // On a grid: one invocation per block of particles.
    if (grid_gather_done(p)) {
        return;
    }
    update_direction(p, work[wi(W_S, p)].xyz, apply_a(W_S, p));
}

// c = s + β c and q = S (A s) + β q for particle p, whose s is `s` and
// (A s)_p, unfiltered, `as_p`.
fn update_direction(p: u32, s: vec3<f32>, as_p: vec3<f32>) {
    let beta = partials[scalar_index(C_BETA)];
    let t = filter_of(p, as_p);
    let c = s + work[wi(W_C, p)].xyz * beta;
    let q = t + work[wi(W_Q, p)].xyz * beta;
    work[wi(W_C, p)] = vec4<f32>(c, 0.0);
    work[wi(W_Q, p)] = vec4<f32>(q, dot3(c, q));
}

// The grid gather (generated/grid_block.wgsl): each particle's s, and
// (A s)_p as apply_a sums it.
struct BlockData {
    s: vec3<f32>,
}

alias BlockAcc = vec3<f32>;

fn block_load(i: u32) -> BlockData {
    return BlockData(work[wi(W_S, i)].xyz);
}

fn block_start(p: u32, own: BlockData) -> vec3<f32> {
    return own.s * v[p].w;
}

// The spring's block (m, a), loaded once for both ends where both are
// members.
alias SpringData = vec4<f32>;

fn spring_load(inc: Incident, first: BlockData, second: BlockData) -> vec4<f32> {
    return spring_block(inc);
}

fn block_term(acc: vec3<f32>, own: BlockData, other: BlockData, inc: Incident, blk: vec4<f32>) -> vec3<f32> {
    return grid_apply_with(acc, inc, own.s, other.s, blk);
}

fn block_end(p: u32, own: BlockData, acc: vec3<f32>) {
    update_direction(p, own.s, acc);
}
