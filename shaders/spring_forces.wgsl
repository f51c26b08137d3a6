// Per spring: the force on end i (twin:
// cpu::forces::spring_forces), for the particles to gather.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

@compute @workgroup_size(WORKGROUP)
fn spring_forces(@builtin(global_invocation_id) gid: vec3<u32>) {
    let s = gid.x;
    if (s >= params.spring_count) {
        return;
    }
    let sp = springs[s];
    let f = spring_force(sp, x[sp.i].xyz, x[sp.j].xyz, v[sp.i].xyz, v[sp.j].xyz);
    spring_work[si(S_FORCE, s)] = vec4<f32>(f, 0.0);
}
