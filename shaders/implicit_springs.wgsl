// Implicit step, per spring: the linearisation at the start of the step.
// Twin: the spring loop of cpu::implicit::step.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"

@compute @workgroup_size(WORKGROUP)
fn implicit_springs(@builtin(global_invocation_id) gid: vec3<u32>) {
    let s = gid.x;
    if (s >= params.spring_count) {
        return;
    }
    let sp = springs[s];
    let dt = params.dt;
    let dt2 = dt * dt;
    let d = x[sp.i].xyz - x[sp.j].xyz;
    let l = len3(d);
    var dir = vec3<f32>(0.0);
    var transverse = 0.0;
    if (l > TINY) {
        dir = d / l;
        transverse = max(1.0 - sp.rest / l, 0.0);
    }
    let a = dt2 * sp.k * transverse;
    let b = dt2 * sp.k - a + dt * sp.kd;
    let m = dir * sqrt(max(b, 0.0));
    let u = v[sp.i].xyz - v[sp.j].xyz;
    let k_long = sp.k * (1.0 - transverse);
    let kv = -(u * (sp.k * transverse) + dir * (k_long * dot3(dir, u)));
    spring_work[si(S_BLOCK, s)] = vec4<f32>(m, a);
    spring_work[si(S_KV, s)] = vec4<f32>(kv, 0.0);
    // On a grid, implicit_prepare computes the forces where it sums them.
    if (!GRID) {
        let f = spring_force(sp, x[sp.i].xyz, x[sp.j].xyz, v[sp.i].xyz, v[sp.j].xyz);
        spring_work[si(S_FORCE, s)] = vec4<f32>(f, 0.0);
    }
}
