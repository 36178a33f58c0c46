// envmap: the environment-map baseline. Every mirror pixel looks its reflected direction up in
// the CMO nearest to the mirror point, as if the scene were infinitely far: no parallax. Its
// "hit point" is where that texel's surface lies seen from the CMO centre (centre + D dir), so
// the same error metrics apply; a texel that captured nothing counts as escaped.
//! import shared/mirror.wgsl

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) {
    let pixel = vec2<u32>(position.xy);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    let k = nearest_cmo(ray.origin);
    let t = dir_to_texel(ray.dir, trace_config.size);
    let d = distance_at(k, t);
    let c = cmo_texel_colour(k, t);
    var status = RECORD_ESCAPED;
    var colour = frame.background;
    var point = ray.origin + ray.dir * frame.t_hi;
    if is_finite_f32(d) {
        status = RECORD_HIT;
        colour = c.xyz;
        point = cmo_centres[k].xyz + ray.dir * d;
    }
    records[pixel.y * frame.width + pixel.x] = PixelRecord(
        ray.origin, status, ray.dir, k, point, 0u, colour,
        t.face, t.x, t.y, 1u, 0u, 1u, 0.0, 0.0, 0xffffffffu, 0u, 0u, 1u, 0u,
    );
}
