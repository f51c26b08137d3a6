// Implicit step, per particle: forces, constraint filter and z, right-hand
// side, block-diagonal preconditioner, warm-started Δv, and the partial
// term of δ0 = (Sb)ᵀP(Sb) in the w of W_RHS; with coarse levels, the
// particle's contributions to its aggregates' D. Twin:
// cpu::implicit::prepare.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/coarse.wgsl"
#include "common/implicit.wgsl"
#include "generated/grid_block.wgsl"

@compute @workgroup_size(WORKGROUP)
fn implicit_prepare(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        implicit_step_start();
    }
    // On a grid: one invocation per block of particles, which linearises
    // the springs itself (no spring pass).
    if (grid_gather_done(p)) {
        return;
    }
    implicit_prepare_item(p, COARSE);
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
        pre_start(p, own.v.w),
        levels_start(p, own.v.w, COARSE),
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
        levels = levels_add(levels, inc.other, sd.blk, COARSE);
    }
    return BlockAcc(acc.f + grid_term(sd.f, inc), acc.kv + grid_term(sd.kv, inc), pre, levels);
}

fn block_end(p: u32, own: BlockData, acc: BlockAcc) {
    let f = force_with_springs(p, acc.f, own.v.w, STATE_BUFFERS);
    prepare_particle(p, own.x, own.v, f, acc.kv, acc.pre, acc.levels, COARSE);
}
