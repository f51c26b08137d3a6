// write_vertices: copies one cloth's positions and vertex normals from the
// solver's buffers into its Bevy mesh's slice of the mesh allocator's
// vertex slab, in the mesh's own interleaved layout, so Bevy's material
// pipelines (PBR, shadows, prepasses) draw the simulated cloth as an
// ordinary mesh. The twin of `WriteLayout` in src/render/write.rs.

struct WriteLayout {
    // The cloth's first particle in `positions` and `normals`.
    source: u32,
    // The mesh's first vertex in the bound slab range, in 32-bit words.
    base: u32,
    // Words per vertex in the slab.
    stride: u32,
    // Word offsets of the position and the normal within a vertex.
    position: u32,
    normal: u32,
    // Particles (= the mesh's vertices).
    count: u32,
    _pad0: u32,
    _pad1: u32,
}

// xyz in m, w = inverse mass (unused here).
@group(0) @binding(0) var<storage, read> positions: array<vec4<f32>>;
// xyz unit, valid after the solver's normals pass.
@group(0) @binding(1) var<storage, read> normals: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> vertices: array<f32>;
@group(0) @binding(3) var<uniform> place: WriteLayout;

@compute @workgroup_size(64)
fn write_vertices(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= place.count {
        return;
    }
    let x = positions[place.source + i].xyz;
    let n = normals[place.source + i].xyz;
    let at = place.base + i * place.stride;
    vertices[at + place.position] = x.x;
    vertices[at + place.position + 1u] = x.y;
    vertices[at + place.position + 2u] = x.z;
    vertices[at + place.normal] = n.x;
    vertices[at + place.normal + 1u] = n.y;
    vertices[at + place.normal + 2u] = n.z;
}
