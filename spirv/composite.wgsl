// composite: the final image. Mirror pixels take their record's colour (unresolved ones the
// fallback: a flag colour, the environment map, or the background; with the trace fallback the
// BVH finished them before this pass, and a ray its loop cap cut shows the flag colour); other
// pixels the G-buffer's shaded colour, or the background where nothing was drawn. Output: linear
// RGB, a = mirror mask.
//
// The environment-map fallback shades from the capture's triangle IDs, not from a captured
// colour (`envmap_fallback` below; CPU twin `cpu::fragment::envmap_fallback`), so that no
// frame of a tracer captures colour for it (`GpuRenderer::new`, `CaptureContents`).
//! import shared/mirror.wgsl
//! import shared/trace_verified.wgsl

// The scene's bind group (shared/scene.wgsl, for the fallback's shading).
const SCENE_GROUP: u32 = 2u;

@group(0) @binding(4) var gbuffer_colour: texture_2d<f32>;
@group(0) @binding(5) var<storage, read_write> frame_colour: array<vec4<f32>>;

// The environment map of CMO `k` in direction `dir` (no parallax), shaded at a point of the
// triangle the texel captured: the ray from the CMO centre along `dir` meets it (watertight,
// shared/watertight.wgsl) and is shaded there (`hit_shade`); where that ray misses it (`dir` is
// off the triangle inside the texel), the texel's centre ray, which the capture saw it along;
// the background where the texel captured nothing or both miss.
fn envmap_fallback(k: u32, dir: vec3<f32>) -> vec3<f32> {
    let n = trace_config.size;
    let t = dir_to_texel(dir, n);
    let id = cmo_triangle[k * 6u * n * n + texel_index(t, n)];
    if id == VERIFY_NO_TRIANGLE || id >= arrayLength(&scene_indices) / 3u {
        return frame.background;
    }
    let c = cmo_centres[k].xyz;
    let p0 = verify_corner(id, 0u);
    let p1 = verify_corner(id, 1u);
    let p2 = verify_corner(id, 2u);
    var h = wt_intersect(c, dir, p0, p1, p2);
    if !h.hit {
        h = wt_intersect(c, texel_centre_dir(t, n), p0, p1, p2);
    }
    if !h.hit {
        return frame.background;
    }
    return hit_shade(id, h.bary.yz);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= frame.width * frame.height {
        return;
    }
    let pixel = vec2<i32>(vec2<u32>(i % frame.width, i / frame.width));
    let p = textureLoad(gbuffer_position, pixel, 0);
    if p.w != 1.0 {
        let c = textureLoad(gbuffer_colour, pixel, 0);
        frame_colour[i] = vec4<f32>(select(frame.background, c.xyz, c.w > 0.0), 0.0);
        return;
    }
    let r = records[i];
    var colour = r.colour;
    if r.status == RECORD_UNRESOLVED {
        switch frame.fallback {
            case 0u, 3u: { colour = frame.flag_colour; }
            case 1u: { colour = envmap_fallback(nearest_cmo(r.origin), r.dir); }
            default: { colour = frame.background; }
        }
    }
    frame_colour[i] = vec4<f32>(colour, 1.0);
}
