// Implicit step, per spring: the linearisation at the start of the step
// (general kernels only: on a grid each kernel linearises the springs it
// uses from the particles' state). Twin:
// cpu::implicit::springs.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

@compute @workgroup_size(WORKGROUP)
fn implicit_springs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let s = gid.x;
    if (s >= params.spring_count) {
        return;
    }
    let sp = springs[s];
    let xi = x[sp.i].xyz;
    let xj = x[sp.j].xyz;
    let vi = v[sp.i].xyz;
    let vj = v[sp.j].xyz;
    let lin = linearise(sp.rest, sp.k, sp.kd, xi, xj, vi, vj);
    spring_work[si(S_BLOCK, s)] = lin.blk;
    spring_work[si(S_KV, s)] = vec4<f32>(lin.kv, 0.0);
    spring_work[si(S_FORCE, s)] = vec4<f32>(lin.f, 0.0);
}
