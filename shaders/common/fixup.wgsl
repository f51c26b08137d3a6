// Provot's fix-up, one particle of one Jacobi pass (twin:
// cpu::fixup::jacobi): shared by the fixup_jacobi kernel, whose pass reads
// and writes the sections its overrides name, and the workgroup kernels,
// which alternate the sections at run time.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// Twin: cpu::fixup SLACK_ULPS × f32::EPSILON.
const SLACK: f32 = 1.0 + 1.1920929e-7 * 64.0;

// Twin: cpu::fixup::correction, with the positions of section `src`.
// Returns the correction c (end i moves by −w_i c, end j by +w_j c) and
// whether the spring is over its limit.
fn fixup_correction(s: u32, src: u32) -> vec4<f32> {
    let sp = spring(s);
    if (sp.max_len <= 0.0) {
        return vec4<f32>(0.0);
    }
    let d = work[wi(src, sp.i)].xyz - work[wi(src, sp.j)].xyz;
    let l = len3(d);
    let w = x[sp.i].w + x[sp.j].w;
    if (l > sp.max_len * SLACK && w > 0.0) {
        return vec4<f32>(d * ((l - sp.max_len) / (l * w)), 1.0);
    }
    return vec4<f32>(0.0);
}

// Writes particle p (source position `xp`, inverse mass `w`) moved by the
// mean of its `count` corrections, whose sum is `sum`, to section `dst`.
// Returns whether any of its springs was over its limit.
fn fixup_move(p: u32, xp: vec3<f32>, w: f32, sum: vec3<f32>, count: u32, dst: u32) -> bool {
    var xn = xp;
    if (count > 0u && w > 0.0) {
        xn += sum * (w * params.fixup_omega / f32(count));
    }
    work[wi(dst, p)] = vec4<f32>(xn, 0.0);
    return count > 0u;
}

// Particle p's pass in general layout: gathers the corrections of its
// springs over their limits from section `src`, in adjacency order, and
// writes its moved position to `dst`. Returns whether it found any.
fn fixup_particle(p: u32, src: u32, dst: u32) -> bool {
    var sum = vec3<f32>(0.0);
    var count = 0u;
    let begin = spring_adj(p);
    let end = spring_adj(p + 1u);
    for (var k = begin; k < end; k++) {
        let e = topo(params.spring_adj_entries + k);
        let c = fixup_correction(e >> 1u, src);
        if (c.w == 0.0) {
            continue;
        }
        if ((e & 1u) == 0u) {
            sum -= c.xyz;
        } else {
            sum += c.xyz;
        }
        count += 1u;
    }
    return fixup_move(p, work[wi(src, p)].xyz, x[p].w, sum, count, dst);
}

// Records that the pass whose flag is STATUS_FIXUP_FLAG + `flag` moved
// something (finish_particle then rebuilds the velocities).
fn fixup_moved(flag: u32) {
    atomicStore(&status[sw(STATUS_FIXUP_MOVED)], 1u);
    atomicStore(&status[sw(STATUS_FIXUP_FLAG + flag)], 1u);
}

// The fix-up's status words at the start of a step's fix-up: nothing
// moved, no pass run, the result in the predicted positions.
fn reset_fixup() {
    atomicStore(&status[sw(STATUS_FIXUP_MOVED)], 0u);
    atomicStore(&status[sw(STATUS_FIXUP_STOPPED)], 0u);
    atomicStore(&status[sw(STATUS_FIXUP_RESULT)], W_X_PRED);
    atomicStore(&status[sw(STATUS_FIXUP_PASSES)], 0u);
    atomicStore(&status[sw(STATUS_FIXUP_FLAG)], 0u);
}
