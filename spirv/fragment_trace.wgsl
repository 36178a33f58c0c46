// fragment_trace: thesis alg. 1 as a deferred full-screen fragment pass. Every mirror pixel of
// the G-buffer traces its reflected ray through the CMOs (`trace_ray`: the criterion, sampling
// and acceleration of `trace_config`, with the occlusion handoff between CMOs) and writes its
// record. The colour of a hit is the captured colour of the deciding texel.
//
// Two entry points, the same code specialised: `fs_main` carries every criterion, sampling and
// acceleration (chosen at run time by `trace_config`); `fs_exact_mip` only the exact criterion's
// mip march, the default options' path (`vk::trace_probe::exact_mip_only` picks it).
//! import shared/mirror.wgsl

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) {
    trace_pixel(position, TRACE_ANY);
}

@fragment
fn fs_exact_mip(@builtin(position) position: vec4<f32>) {
    trace_pixel(position, TRACE_EXACT_MIP);
}

// Traces the mirror pixel at `position` with `variant` (a constant, see `trace_ray_variant`).
fn trace_pixel(position: vec4<f32>, variant: u32) {
    let pixel = vec2<u32>(position.xy);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    let r = trace_ray_variant(ray.origin, ray.dir, 0.0, frame.t_hi, variant);
    var colour = frame.background;
    if r.status == STATUS_HIT {
        colour = cmo_texel_colour(r.cmo, Texel(r.face, r.x, r.y)).xyz;
    }
    records[pixel.y * frame.width + pixel.x] = PixelRecord(
        ray.origin, r.status, ray.dir, r.cmo, r.point, r.riser, colour,
        r.face, r.x, r.y, r.texels, r.cells, r.traces, r.t, r.t_done, 0u,
    );
}
