// Torque compensation, pass 3: Δv −= ω × r with ω = I⁻¹ ΔL.
#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"
#include "common/torque.wgsl"

var<workgroup> shared_omega: vec4<f32>;

@compute @workgroup_size(WORKGROUP)
fn torque_apply(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
) {
    let centre = centre_of_mass(lid.x);
    if (lid.x == 0u) {
        let e = vec3<f32>(
            sum_partials(torque_slot(T_EXCESS)),
            sum_partials(torque_slot(T_EXCESS + 1u)),
            sum_partials(torque_slot(T_EXCESS + 2u)),
        );
        let inertia = Sym3(
            vec3<f32>(
                sum_partials(torque_slot(T_INERTIA)),
                sum_partials(torque_slot(T_INERTIA + 1u)),
                sum_partials(torque_slot(T_INERTIA + 2u)),
            ),
            vec3<f32>(
                sum_partials(torque_slot(T_INERTIA + 3u)),
                sum_partials(torque_slot(T_INERTIA + 4u)),
                sum_partials(torque_slot(T_INERTIA + 5u)),
            ),
        );
        // A singular tensor (twin: inverse() is None) leaves Δv as it is.
        var omega = vec4<f32>(0.0);
        let inv = sym3_inverse(inertia);
        if (inv.ok) {
            omega = vec4<f32>(sym3_mul(inv.m, e), 1.0);
        }
        shared_omega = omega;
    }
    let omega = workgroupUniformLoad(&shared_omega);
    let p = gid.x;
    if (p < params.particle_count && omega.w != 0.0) {
        let dv = work[wi(W_DV, p)].xyz - cross3(omega.xyz, x[p].xyz - centre);
        work[wi(W_DV, p)] = vec4<f32>(dv, 0.0);
    }
}
