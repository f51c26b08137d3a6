// Implicit step, per particle: forces, constraint filter and z, right-hand
// side, block-diagonal preconditioner, warm-started Δv, and the partial
// term of δ0 = (Sb)ᵀP(Sb) in the w of W_RHS. Twin: the particle loop of cpu::implicit::step.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

// Twin: cpu::collide::CONTACT_SLOP.
const CONTACT_SLOP: f32 = 1e-5;

@compute @workgroup_size(WORKGROUP)
fn implicit_prepare(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p == 0u) {
        atomicAdd(&status[STATUS_STEP], 1u);
        atomicStore(&status[STATUS_CG_ITERATIONS], 0u);
        atomicStore(&status[STATUS_CG_STOPPED], 0u);
    }
    if (p < params.particle_count) {
        let x0 = x[p];
        let v0 = v[p];
        let f = total_force(p, x0, v0, STATE_BUFFERS);
        let m = v0.w;
        let vp = v0.xyz;
        var kind = FILTER_FREE;
        var normal = vec3<f32>(0.0);
        var friction = 0.0;
        var z = vec3<f32>(0.0);
        if (x0.w <= 0.0) {
            kind = FILTER_FIXED;
            z = -vp;
        } else {
            let c = find_contact(x0.xyz, CONTACT_SLOP);
            if (c.found && (dot3(f, c.normal) < 0.0 || dot3(vp, c.normal) < 0.0)) {
                kind = FILTER_PLANE;
                normal = c.normal;
                friction = c.friction;
                z = normal * (-min(dot3(vp, normal), 0.0));
            }
        }
        // K v, gathered like gather_signed: its own accumulator.
        var kv = vec3<f32>(0.0);
        // Preconditioner: m I plus a I + b n nᵀ of every incident spring.
        var xx = m;
        var yy = m;
        var zz = m;
        var xy = 0.0;
        var xz = 0.0;
        var yz = 0.0;
        let begin = topo[p];
        let end = topo[p + 1u];
        for (var k = begin; k < end; k++) {
            let e = topo[params.spring_adj_entries + k];
            let s = e >> 1u;
            let kvs = spring_work[si(S_KV, s)].xyz;
            kv += select(kvs, -kvs, (e & 1u) != 0u);
            // Twin: Sym3::add_iso_aniso(a, 1, m).
            let blk = spring_work[si(S_BLOCK, s)];
            let a = blk.w;
            let m = blk.xyz;
            xx += a + m.x * m.x;
            yy += a + m.y * m.y;
            zz += a + m.z * m.z;
            xy += m.x * m.y;
            xz += m.x * m.z;
            yz += m.y * m.z;
        }
        let rhs = (f + kv * params.dt) * params.dt;
        // Twin: Sym3::inverse, with its fallback to 1/m I.
        var pre = Sym3(vec3<f32>(1.0 / m), vec3<f32>(0.0));
        let inv = sym3_inverse(Sym3(vec3<f32>(xx, yy, zz), vec3<f32>(xy, xz, yz)));
        if (inv.ok) {
            pre = inv.m;
        }
        work[wi(W_Z, p)] = vec4<f32>(z, kind);
        work[wi(W_FILTER, p)] = vec4<f32>(normal, friction);
        work[wi(W_PRE_DIAG, p)] = vec4<f32>(pre.d, 0.0);
        work[wi(W_PRE_OFF, p)] = vec4<f32>(pre.o, 0.0);
        let dv = filter_apply(kind, normal, warm_start(p)) + z;
        work[wi(W_DV, p)] = vec4<f32>(dv, 0.0);
        let sb = filter_apply(kind, normal, rhs);
        work[wi(W_RHS, p)] = vec4<f32>(rhs, dot3(sb, precond_mul(p, sb)));
    }
}
