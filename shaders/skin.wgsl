// Per render vertex: its position and normal on the cloth, written into
// the host's vertex buffer at the words its layout names
// (gpu::render_mesh::SkinLayout). Reads the normals the cloth's `normals`
// pass wrote since its last step.
#include "common/skin.wgsl"

@compute @workgroup_size(WORKGROUP)
fn skin(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= skin_params.count) {
        return;
    }
    let s = skin_vertex(embedded[i]);
    let base = skin_params.base + i * skin_params.stride;
    let p = base + skin_params.position;
    skinned[p] = s.position.x;
    skinned[p + 1u] = s.position.y;
    skinned[p + 2u] = s.position.z;
    if (skin_params.normal != NO_NORMAL) {
        let q = base + skin_params.normal;
        skinned[q] = s.normal.x;
        skinned[q + 1u] = s.normal.y;
        skinned[q + 2u] = s.normal.z;
    }
}
