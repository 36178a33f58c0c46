// fragment_trace: thesis alg. 1 as a deferred full-screen fragment pass. Every mirror pixel of
// the G-buffer traces its reflected ray through the CMOs (`trace_ray`: the criterion, sampling
// and acceleration of `trace_config`, with the occlusion handoff between CMOs) and writes its
// record. The colour of a hit is the captured colour of the deciding texel.
//! import shared/mirror.wgsl

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) {
    let pixel = vec2<u32>(position.xy);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    let r = trace_ray(ray.origin, ray.dir, 0.0, frame.t_hi);
    var colour = frame.background;
    if r.status == STATUS_HIT {
        colour = cmo_texel_colour(r.cmo, Texel(r.face, r.x, r.y)).xyz;
    }
    records[pixel.y * frame.width + pixel.x] = PixelRecord(
        ray.origin, r.status, ray.dir, r.cmo, r.point, r.riser, colour,
        r.face, r.x, r.y, r.texels, r.cells, r.traces, r.t, r.t_done, 0u,
    );
}
