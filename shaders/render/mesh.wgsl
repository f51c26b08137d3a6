// The offscreen renderer's one shader: the cloth (drawn straight from the
// solver's position and normal buffers) and the colliders (a unit mesh
// placed per instance). Twin of `Globals` in `src/render/mod.rs`.

struct Globals {
    view_proj: mat4x4<f32>,
    // Direction towards the light (unit, world space); w unused.
    light: vec4<f32>,
    // Colour of the cloth's front side (linear RGB); w unused.
    cloth_front: vec4<f32>,
    // Colour of its back side.
    cloth_back: vec4<f32>,
    // x: the stretch strain shown red in the strain view; yzw unused.
    strain: vec4<f32>,
}

@group(0) @binding(0) var<uniform> globals: Globals;

// The strain view reads the mesh as storage: the solver's positions and
// normals, and the renderer's copies of the rest positions and triangles
// (the solver's index buffer is an index buffer only).
@group(1) @binding(0) var<storage, read> positions: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> normals: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> rest: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> triangles: array<u32>;

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // rgb: front colour; w: 1 for a checkered surface (the ground).
    @location(2) front: vec4<f32>,
    @location(3) back: vec3<f32>,
}

// The cloth: slot 0 is the solver's positions (vec4 per particle, xyz
// used), slot 1 its normals; the instance's tint (the last slot) is the
// colour of one cloth of a world (w 1: its rgb, linear; w 0: the
// globals' colours), its back side paler, as the globals' is, so that a
// fold shows which side is up.
@vertex
fn vs_cloth(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) tint: vec4<f32>,
) -> VertexOut {
    var out: VertexOut;
    out.clip = globals.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    out.normal = normal;
    let own = tint.w > 0.5;
    out.front = vec4<f32>(select(globals.cloth_front.rgb, tint.rgb, own), 0.0);
    out.back = select(globals.cloth_back.rgb, mix(tint.rgb, vec3<f32>(1.0), 0.35), own);
    return out;
}

// The strain view: drawn without an index buffer, three vertices per
// triangle, so that each vertex can see its whole triangle and colour it
// by its largest edge strain (l − L) / L: blue at ≤ 0, green at half of
// `globals.strain.x`, red at and above it.
@vertex
fn vs_cloth_strain(@builtin(vertex_index) v: u32) -> VertexOut {
    let t = 3u * (v / 3u);
    let ids = vec3<u32>(triangles[t], triangles[t + 1u], triangles[t + 2u]);
    var strain = -1.0;
    for (var k = 0u; k < 3u; k++) {
        let a = ids[k];
        let b = ids[(k + 1u) % 3u];
        let l = length(positions[a].xyz - positions[b].xyz);
        let l0 = length(rest[a].xyz - rest[b].xyz);
        strain = max(strain, (l - l0) / max(l0, 1e-12));
    }
    let s = clamp(strain / max(globals.strain.x, 1e-12), 0.0, 1.0);
    let blue = vec3<f32>(0.05, 0.15, 0.9);
    let green = vec3<f32>(0.1, 0.75, 0.1);
    let red = vec3<f32>(0.9, 0.05, 0.05);
    let colour = select(mix(green, red, 2.0 * s - 1.0), mix(blue, green, 2.0 * s), s < 0.5);
    let p = ids[v % 3u];
    var out: VertexOut;
    out.clip = globals.view_proj * vec4<f32>(positions[p].xyz, 1.0);
    out.world = positions[p].xyz;
    out.normal = normals[p].xyz;
    out.front = vec4<f32>(colour, 0.0);
    out.back = colour;
    return out;
}

// A collider: a unit mesh (slot 0) scaled and moved by its instance
// (slot 1: centre xyz, scale w; colour rgb, checker flag w; half the
// capsule's segment xyz). A capsule mesh's vertex (|y| ≥ 1 up to
// rounding) follows the end of its sign: the unit capsule's ends at y = ±1
// go to centre ± axis, its cross-sections turned to face the axis; a zero
// axis draws a sphere. A quad (y = 0) follows neither.
@vertex
fn vs_collider(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) place: vec4<f32>,
    @location(3) colour: vec4<f32>,
    @location(4) axis: vec4<f32>,
) -> VertexOut {
    var out: VertexOut;
    let side = select(0.0, sign(position.y), abs(position.y) > 0.5);
    // A right-handed frame (v, u, w) with u along the axis: v × u = w.
    var u = vec3<f32>(0.0, 1.0, 0.0);
    var v = vec3<f32>(1.0, 0.0, 0.0);
    var w = vec3<f32>(0.0, 0.0, 1.0);
    let len = length(axis.xyz);
    if (len > 1e-6) {
        u = axis.xyz / len;
        let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 0.0, 1.0), abs(u.x) > 0.9);
        w = normalize(cross(helper, u));
        v = cross(u, w);
    }
    let p = vec3<f32>(position.x, position.y - side, position.z);
    let turned = p.x * v + p.y * u + p.z * w;
    let world = place.xyz + place.w * turned + side * axis.xyz;
    out.clip = globals.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.normal = normal.x * v + normal.y * u + normal.z * w;
    out.front = colour;
    out.back = colour.rgb;
    return out;
}

// True when the colour target is an `*Srgb` format (set by the host from
// its format: `RendererFormats` in `src/render/mod.rs`). Such a target
// sRGB-encodes what the shader writes, so the shader writes the linear
// value whose encoding is the colour a plain target would store: the
// picture is the same on both.
override SRGB_TARGET: bool = false;

// The sRGB transfer function's inverse (IEC 61966-2-1), per channel: an
// encoded value in [0, 1] to linear. Twin of `srgb_to_linear` in
// `src/render/mod.rs`.
fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let curve = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(curve, c / 12.92, c <= vec3<f32>(0.04045));
}

// Two-sided Lambert plus ambient, gamma-encoded by hand (the PNG frames
// are read from a plain `Rgba8Unorm` target so that the clear colour's
// bytes are exact); on an sRGB target, decoded again for the hardware's
// encode (see `SRGB_TARGET`).
@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    var n = normalize(in.normal);
    var base = in.front.rgb;
    if !front_facing {
        // The back of the cloth: its normal points away from the eye.
        n = -n;
        base = in.back;
    }
    if in.front.w > 0.5 {
        // 0.25 m checkers: the ground shows scale and motion.
        let cell = floor(in.world.xz / 0.25);
        if (i32(cell.x + cell.y) & 1) == 1 {
            base = base * 0.8;
        }
    }
    let diffuse = max(dot(n, globals.light.xyz), 0.0);
    let linear = base * (0.3 + 0.7 * diffuse);
    let encoded = pow(linear, vec3<f32>(1.0 / 2.2));
    if SRGB_TARGET {
        return vec4<f32>(srgb_to_linear(encoded), 1.0);
    }
    return vec4<f32>(encoded, 1.0);
}
