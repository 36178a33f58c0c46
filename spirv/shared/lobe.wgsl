// Glossy reflection: the Phong lobe's per-sample directions, `cubetrace::lobe` (src/lobe.rs)
// operation for operation, so that `--method bvh` reflects a glossy pixel's sample along the
// direction the CPU reference takes (up to the device's own exp2, log2, sin and cos). The rules
// (the mirror cap, Eq. 4.1, the basis, the absorbed directions below the surface, the hash) are
// documented there.
//
// The G-buffer carries a glossy reflector's power in its normal's w as -1 - p
// (spirv/gbuffer.wgsl); a mirror and every other surface hold 1 there.

const LOBE_SEED: u32 = 0x9e3779b9u;
// `std::f32::consts::TAU` as an f32.
const LOBE_TAU: f32 = 6.2831855;

// A glossy reflector's specular power from the G-buffer normal's w; -1 where the pixel is no
// glossy reflector.
fn lobe_gbuffer_power(w: f32) -> f32 {
    return select(-1.0, -1.0 - w, w <= -1.0);
}

// `lobe::pcg`.
fn lobe_pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn lobe_unit(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// `lobe::uniforms`.
fn lobe_uniforms(x: u32, y: u32, key: u32, bounce: u32) -> vec2<f32> {
    let h = lobe_pcg(lobe_pcg(lobe_pcg(lobe_pcg(LOBE_SEED ^ bounce) ^ key) ^ x) ^ y);
    let a = lobe_pcg(h);
    let b = lobe_pcg(a);
    return vec2<f32>(lobe_unit(a), lobe_unit(b));
}

fn lobe_dot(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// glam's `normalize`: the reciprocal of the length, then a multiply.
fn lobe_normalize(v: vec3<f32>) -> vec3<f32> {
    return v * (1.0 / sqrt(lobe_dot(v, v)));
}

// `lobe::sample_around`: the direction of the lobe of power `power` around the unit `axis`.
fn lobe_sample_around(axis: vec3<f32>, power: f32, u: vec2<f32>) -> vec3<f32> {
    let c = exp2(log2(1.0 - u.x) / (power + 1.0));
    let s = sqrt(max(1.0 - c * c, 0.0));
    let phi = LOBE_TAU * u.y;
    // `lobe::basis` (Duff et al. 2017).
    let sign = select(-1.0, 1.0, axis.z >= 0.0);
    let a = -1.0 / (sign + axis.z);
    let b = axis.x * axis.y * a;
    let t = vec3<f32>(1.0 + sign * (axis.x * axis.x) * a, sign * b, -sign * axis.x);
    let bb = vec3<f32>(b, sign + (axis.y * axis.y) * a, -axis.y);
    let sp = sin(phi);
    let cp = cos(phi);
    return lobe_normalize(t * (s * cp) + bb * (s * sp) + axis * c);
}

struct LobeSample {
    // False where the direction lies below the surface: the sample is absorbed.
    above: bool,
    dir: vec3<f32>,
}

// `lobe::sample`: a lobe direction around the unit mirror direction `mirror` at a surface of
// unit shading normal `normal`.
fn lobe_sample(mirror: vec3<f32>, normal: vec3<f32>, power: f32, u: vec2<f32>) -> LobeSample {
    let d = lobe_sample_around(mirror, power, u);
    return LobeSample(lobe_dot(d, normal) * lobe_dot(mirror, normal) > 0.0, d);
}

// `lobe::cone_half_angle`: the half-angle of the cone standing in for the lobe of power `power`
// (Eq. 4.1 at xi = 0.244; 0 at and above the mirror cap, 1024).
fn lobe_cone_angle(power: f32) -> f32 {
    if power >= 1024.0 {
        return 0.0;
    }
    return acos(exp2(log2(0.244) / (max(power, 0.0) + 1.0)));
}
