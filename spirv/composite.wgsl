// composite: the final image. Mirror pixels take their record's colour (unresolved ones the
// fallback: a flag colour, the environment map, or the background; with the trace fallback the
// BVH finished them before this pass, and a ray its loop cap cut shows the flag colour); other pixels the G-buffer's
// shaded colour, or the background where nothing was drawn. Output: linear RGB, a = mirror mask.
//! import shared/mirror.wgsl

@group(0) @binding(4) var gbuffer_colour: texture_2d<f32>;
@group(0) @binding(5) var<storage, read_write> frame_colour: array<vec4<f32>>;

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
            case 1u: { colour = envmap_colour(nearest_cmo(r.origin), r.dir); }
            default: { colour = frame.background; }
        }
    }
    frame_colour[i] = vec4<f32>(colour, 1.0);
}
