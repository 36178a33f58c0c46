// ssr_blur: the pre-convolved colour chain (section 4.4.4, Listing 4.6), in the min pyramid's
// levels, each level one horizontal and one vertical pass of the listing's 7-tap Gaussian
// (weights 0.001, 0.028, 0.233, 0.474, 0.233, 0.028, 0.001 as printed; they sum to 0.998, not to
// 1 as the text says, so each level keeps 99.6 % of the energy). CPU twin:
// `cubetrace::cpu::ssr_cone::build_colour_chain`.
//
// Dispatches (`ConeLevel::stage`): stage 0 writes level 0, the G-buffer's shaded colour (the
// background where nothing was drawn). For each level l >= 1, stage 1 blurs level l - 1
// horizontally into `scratch` (level l - 1's size; taps clamped to the edge, as the listing's
// sampler), then stage 2 blurs `scratch` vertically at the (up to) 2 x 2 texels below each cell of
// level l and averages them. The listing samples level l - 1 with a point sampler at level l's
// texel centre, which lies on the corner of four finer texels and picks one of them, moving each
// level a quarter of its texel right and down (half a coarse texel, summed over the levels); the
// average of the four is the bilinear tap at that corner, unshifted.
//! import shared/ssr.wgsl
//! import shared/ssr_cone.wgsl

@group(0) @binding(0) var<storage, read> ssr: SsrParams;
@group(0) @binding(1) var gbuffer_colour: texture_2d<f32>;
@group(0) @binding(2) var<storage, read_write> chain: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> scratch: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> cone_level: ConeLevel;

const WG: u32 = 64u;
const G0: f32 = 0.001;
const G1: f32 = 0.028;
const G2: f32 = 0.233;
const G3: f32 = 0.474;

fn tap(i: i32, n: u32) -> u32 {
    return u32(clamp(i, 0, i32(n) - 1));
}

// The horizontal blur of `chain`'s level `src` at texel (x, y), into `scratch`.
fn blur_row(src: vec4<u32>, x: i32, y: u32) -> vec4<f32> {
    let row = src.x + y * src.y;
    var c = chain[row + tap(x - 3, src.y)] * G0;
    c = c + chain[row + tap(x - 2, src.y)] * G1;
    c = c + chain[row + tap(x - 1, src.y)] * G2;
    c = c + chain[row + tap(x, src.y)] * G3;
    c = c + chain[row + tap(x + 1, src.y)] * G2;
    c = c + chain[row + tap(x + 2, src.y)] * G1;
    c = c + chain[row + tap(x + 3, src.y)] * G0;
    return c;
}

// The vertical blur of `scratch` (level `src`'s size) at texel (x, y).
fn blur_column(src: vec4<u32>, x: u32, y: i32) -> vec4<f32> {
    var c = scratch[tap(y - 3, src.z) * src.y + x] * G0;
    c = c + scratch[tap(y - 2, src.z) * src.y + x] * G1;
    c = c + scratch[tap(y - 1, src.z) * src.y + x] * G2;
    c = c + scratch[tap(y, src.z) * src.y + x] * G3;
    c = c + scratch[tap(y + 1, src.z) * src.y + x] * G2;
    c = c + scratch[tap(y + 2, src.z) * src.y + x] * G1;
    c = c + scratch[tap(y + 3, src.z) * src.y + x] * G0;
    return c;
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let index = gid.y * (groups.x * WG) + gid.x;
    let l = cone_level.level;
    let stage = cone_level.stage;
    // No barrier in this shader: an early return is uniform-safe.
    if stage == 0u {
        let dst = ssr.levels[0];
        if index >= dst.y * dst.z {
            return;
        }
        let c = textureLoad(gbuffer_colour, vec2<i32>(vec2<u32>(index % dst.y, index / dst.y)), 0);
        chain[index] = vec4<f32>(select(cone_level.background.xyz, c.xyz, c.w > 0.0), 1.0);
        return;
    }
    let src = ssr.levels[l - 1u];
    if stage == 1u {
        if index >= src.y * src.z {
            return;
        }
        scratch[index] = blur_row(src, i32(index % src.y), index / src.y);
        return;
    }
    let dst = ssr.levels[l];
    if index >= dst.y * dst.z {
        return;
    }
    let sx = 2u * (index % dst.y);
    let sy = 2u * (index / dst.y);
    var sum = blur_column(src, sx, i32(sy));
    var n = 1.0;
    if sx + 1u < src.y {
        sum = sum + blur_column(src, sx + 1u, i32(sy));
        n = n + 1.0;
    }
    if sy + 1u < src.z {
        sum = sum + blur_column(src, sx, i32(sy + 1u));
        n = n + 1.0;
        if sx + 1u < src.y {
            sum = sum + blur_column(src, sx + 1u, i32(sy + 1u));
            n = n + 1.0;
        }
    }
    chain[dst.x + index] = sum / n;
}
