// Shared by the torque-compensation kernels (twin:
// cpu::torque): the centre of mass from the
// partial sums of torque_centre.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"
#include "common/cg.wgsl"

var<workgroup> shared_vec: vec4<f32>;

const T_MASS: u32 = 0u;      // Σ m
const T_MX: u32 = 1u;        // Σ m x (3 slots)
const T_EXCESS: u32 = 4u;    // Σ r × (m Δv − dt f_ext) (3 slots)
const T_INERTIA: u32 = 7u;   // Σ m (|r|² I − r rᵀ) (6 slots)

fn torque_slot(k: u32) -> u32 {
    return P_TORQUE + k;
}

// The centre of mass, computed by invocation 0 and shared.
fn centre_of_mass(lid: u32) -> vec3<f32> {
    if (lid == 0u) {
        let total = sum_partials(torque_slot(T_MASS));
        let c = vec3<f32>(
            sum_partials(torque_slot(T_MX)),
            sum_partials(torque_slot(T_MX + 1u)),
            sum_partials(torque_slot(T_MX + 2u)),
        ) / total;
        shared_vec = vec4<f32>(c, 0.0);
    }
    return workgroupUniformLoad(&shared_vec).xyz;
}
