// The agreement probe (tests/gpu_common/agreement.rs): does this adapter
// round every operation as the f32 CPU mirror does? Every input comes from
// a storage buffer, so no compiler can fold it; each output is one
// operation (or one expression a compiler may contract) on loaded values.
//
// inputs:  [0..3)  a, b, c with a·b + c exact ≠ round(a·b) + c
//          [3]     a subnormal s, [4] one
//          [HEAD + 2k], [HEAD + 2k + 1]  numerator and denominator k
//          [HEAD + 2 SAMPLES + k]        radicand k
// outputs: [0] a·b + c, [1] s·one, [2 + k] quotient k,
//          [2 + SAMPLES + k] square root k

const HEAD: u32 = 5u;
const SAMPLES: u32 = 1024u;

@group(0) @binding(0) var<storage, read> inputs: array<f32>;
@group(0) @binding(1) var<storage, read_write> outputs: array<f32>;

@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if (k == 0u) {
        outputs[0] = inputs[0] * inputs[1] + inputs[2];
        outputs[1] = inputs[3] * inputs[4];
    }
    if (k < SAMPLES) {
        outputs[2u + k] = inputs[HEAD + 2u * k] / inputs[HEAD + 2u * k + 1u];
        outputs[2u + SAMPLES + k] = sqrt(inputs[HEAD + 2u * SAMPLES + k]);
    }
}
