// Vector arithmetic written out in the CPU mirror's order (src/real.rs):
// no built-in `length`, `dot` or `cross`, whose evaluation order and fused
// multiply-adds are the implementation's choice. Needs no binding, so a
// kernel with bindings of its own (skin.wgsl) includes it too.

// A length below which a spring or triangle has no direction. Twin:
// Real::TINY for f32.
const TINY: f32 = 1e-9;

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

fn len3(a: vec3<f32>) -> f32 {
    return sqrt(dot3(a, a));
}

// n / |n|, or `fallback` where |n| is at most TINY (twin:
// cpu::skin::normalize_or).
fn normalize_or(n: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l = len3(n);
    if (l > TINY) {
        return n / l;
    }
    return fallback;
}
