// Per render vertex: its position and normal on the cloth, written into
// the host's vertex buffer at the words its layout names
// (gpu::render_mesh::SkinLayout). Reads the normals the `normals` pass
// wrote since the last step.
#include "common/skin.wgsl"

struct SkinParams {
    // Render vertices.
    count: u32,
    // f32 words from one vertex to the next.
    stride: u32,
    // The word of the position's x in a vertex.
    position: u32,
    // The word of the normal's x (NO_NORMAL: none written).
    normal: u32,
}

const NO_NORMAL: u32 = 0xffffffffu;

@group(1) @binding(0) var<storage, read> embedded: array<Embedded>;
@group(1) @binding(1) var<storage, read_write> skinned: array<f32>;
@group(1) @binding(2) var<uniform> skin_params: SkinParams;

@compute @workgroup_size(WORKGROUP)
fn skin(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= skin_params.count) {
        return;
    }
    let s = skin_vertex(embedded[i]);
    let base = i * skin_params.stride;
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
