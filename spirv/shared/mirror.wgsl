// What every reflection method shares: the mirror pixels' rays from the G-buffer, the per-pixel
// record a method writes, the captured colours, and the full-screen triangle.
//
// Conventions:
// - The reflected ray of a mirror pixel starts at the G-buffer's world position `p` (the
//   pixel-centre ray's hit, spirv/gbuffer.wgsl) and goes along `reflect(d, n)`, `d` the camera's
//   ray through the pixel centre (`camera_ray_dir`), `n` the normalised interpolated vertex
//   normal, as the CPU reference reflects (`reference::reflect`, then normalised). `t` runs over
//   [0, frame.t_hi] in world units (the direction is unit length); `t_hi` reaches past the scene.
// - `records[j * width + i]` is pixel (i, j), row 0 at the top. Only mirror pixels are written;
//   composite reads the mask from the G-buffer before it reads a record.
// - Status: 0 hit, 1 escaped (the ray left the scene: background), 2 unresolved (no CMO saw
//   the surface; composite fills it with the fallback).
//! import shared/trace.wgsl
//! import shared/record.wgsl
//! import shared/camera.wgsl

struct FrameParams {
    eye: vec3<f32>,
    // Length of every reflected ray (world units).
    t_hi: f32,
    background: vec3<f32>,
    width: u32,
    // Colour of unresolved pixels with the flag fallback.
    flag_colour: vec3<f32>,
    height: u32,
    // 0 flag colour, 1 environment map, 2 background, 3 trace (the BVH finished the rays; a ray
    // its loop cap cut gets the flag colour).
    fallback: u32,
    // The reflector check traces the mirror rays `d` with `dot(d, n) < check_below`, `n` the
    // normalised interpolated normal (`Scene::check_below`: 2, every ray, or a bound for the
    // rays that leave a convex reflector below a face's plane).
    check_below: f32,
    // `Camera::ray`'s inputs (`camera_ray_dir`): the mirror pixels' incoming direction is the
    // reference's primary ray, bit for bit.
    tan_half: f32,
    aspect: f32,
    right: vec3<f32>,
    // `Camera::jitter`: the sample's offset from the pixel centre, in pixels.
    jitter_x: f32,
    up: vec3<f32>,
    jitter_y: f32,
    back: vec3<f32>,
    // The film's sample key (`lobe::sample_key`: spp and the sample's index), for the glossy
    // lobe's directions (shared/lobe.wgsl); 0 outside a film's sample loop.
    sample: u32,
}


@group(0) @binding(0) var gbuffer_position: texture_2d<f32>;
@group(0) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(0) @binding(2) var<storage, read> frame: FrameParams;
@group(0) @binding(3) var<storage, read_write> records: array<PixelRecord>;
// Layer 6 k + face: CMO k's face (an image: no storage-buffer size limit).
@group(1) @binding(4) var cmo_colour: texture_2d_array<f32>;

struct MirrorRay {
    mirror: bool,
    origin: vec3<f32>,
    dir: vec3<f32>,
}

fn mirror_ray(pixel: vec2<u32>) -> MirrorRay {
    let p = textureLoad(gbuffer_position, vec2<i32>(pixel), 0);
    if p.w != 1.0 {
        return MirrorRay(false, vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let n = normalize_glam(textureLoad(gbuffer_normal, vec2<i32>(pixel), 0).xyz);
    let d = camera_ray_dir(
        pixel, vec2<f32>(frame.jitter_x, frame.jitter_y), f32(frame.width), f32(frame.height),
        frame.tan_half, frame.aspect,
        frame.right, frame.up, frame.back,
    );
    let dn = d.x * n.x + d.y * n.y + d.z * n.z;
    let r = normalize_glam(d - n * (2.0 * dn));
    return MirrorRay(true, p.xyz, r);
}

// Captured colour of texel `t` of CMO `k`.
fn cmo_texel_colour(k: u32, t: Texel) -> vec4<f32> {
    return textureLoad(cmo_colour, vec2<u32>(t.x, t.y), k * 6u + t.face, 0);
}

// The CMO whose centre is nearest to `p` (the first on ties).
fn nearest_cmo(p: vec3<f32>) -> u32 {
    var best = 0u;
    var best_d = f32_inf();
    for (var k = 0u; k < trace_config.cmo_count; k++) {
        let v = p - cmo_centres[k].xyz;
        let d = dot(v, v);
        if d < best_d {
            best_d = d;
            best = k;
        }
    }
    return best;
}

// A triangle that covers the whole target.
@vertex
fn vs_fullscreen(@builtin(vertex_index) vertex: u32) -> @builtin(position) vec4<f32> {
    let x = f32((vertex << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(vertex & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}
