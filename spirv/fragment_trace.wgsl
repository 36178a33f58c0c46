// fragment_trace: thesis alg. 1 as a deferred full-screen fragment pass. Every mirror pixel of
// the G-buffer traces its reflected ray through the CMOs (`trace_ray`: the criterion, sampling
// and acceleration of `trace_config`, with the occlusion handoff between CMOs) and writes its
// record. With the centre criterion every hit is verified against the captured triangle IDs
// (shared/trace_verified.wgsl): the record's point is on the hit triangle, `triangle` names it and
// the colour is shaded there (`hit_shade`, the reference's shading). With the thesis's
// approximate criteria the colour of a hit is the captured colour of the deciding texel.
//
// Two entry points, the same code specialised: `fs_main` carries every criterion, sampling and
// acceleration (chosen at run time by `trace_config`); `fs_exact_mip` only the centre criterion's
// mip march, the default options' path (`vk::passes::cmo::exact_mip_only` picks it);
// `fs_bounded` only the `bounded` criterion (shared/trace_bounded.wgsl: the pyramid march over
// the candidate lists, the ray leaving the G-buffer's triangle), picked for `--criterion bounded`.
//! import shared/mirror.wgsl
//! import shared/trace_verified.wgsl
//! import shared/trace_bounded.wgsl

// The scene's bind group (shared/scene.wgsl): group 0 is the frame's (shared/mirror.wgsl).
const SCENE_GROUP: u32 = 2u;

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) {
    trace_pixel(position, TRACE_ANY);
}

@fragment
fn fs_exact_mip(@builtin(position) position: vec4<f32>) {
    trace_pixel(position, TRACE_EXACT_MIP);
}

// The G-buffer's global triangle ID (u32::MAX where none): the start triangle of a bounded ray.
@group(0) @binding(8) var gbuffer_triangle: texture_2d<u32>;

@fragment
fn fs_bounded(@builtin(position) position: vec4<f32>) {
    let pixel = vec2<u32>(position.xy);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    let from_tri = textureLoad(gbuffer_triangle, vec2<i32>(pixel), 0).x;
    let b = trace_ray_bounded(ray.origin, ray.dir, 0.0, frame.t_hi, from_tri);
    let v = b.v;
    var colour = frame.background;
    if v.out.status == STATUS_HIT {
        colour = hit_shade(v.triangle, v.bary.yz);
    }
    write_record(pixel, ray, v.out, colour, v.triangle, select(0u, 1u, b.cut));
}

// Traces the mirror pixel at `position` with `variant` (a constant, see `trace_ray_variant`).
fn trace_pixel(position: vec4<f32>, variant: u32) {
    let pixel = vec2<u32>(position.xy);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    var colour = frame.background;
    var r: TraceOut;
    var triangle = VERIFY_NO_TRIANGLE;
    if variant == TRACE_EXACT_MIP || trace_config.criterion == CRITERION_CENTRE {
        let v = trace_ray_verified(ray.origin, ray.dir, 0.0, frame.t_hi, variant);
        r = v.out;
        if r.status == STATUS_HIT {
            triangle = v.triangle;
            colour = hit_shade(v.triangle, v.bary.yz);
        }
    } else {
        r = trace_ray_variant(ray.origin, ray.dir, 0.0, frame.t_hi, variant);
        if r.status == STATUS_HIT {
            colour = cmo_texel_colour(r.cmo, Texel(r.face, r.x, r.y)).xyz;
        }
    }
    write_record(pixel, ray, r, colour, triangle, 0u);
}

// `cut`: 1 where the bounded trace stopped at its back-edge cap (shared/trace_bounded.wgsl).
fn write_record(pixel: vec2<u32>, ray: MirrorRay, r: TraceOut, colour: vec3<f32>, triangle: u32, cut: u32) {
    records[pixel.y * frame.width + pixel.x] = PixelRecord(
        ray.origin, r.status, ray.dir, r.cmo, r.point, r.riser, colour,
        r.face, r.x, r.y, r.texels, r.cells, r.traces, r.t, r.t_done, triangle, cut, 0u, 1u, 0u,
    );
}
