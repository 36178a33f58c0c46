// The `cone` pass: cone tracing on the cube maps for the glossy pixels of the fragment and
// compute methods. It runs after the method's trace, the reflector check and
// the fallback, before the bounce rounds and composite, and only for a scene with a glossy
// reflector. One invocation per glossy pixel; it rewrites the record's colour of a glossy pixel,
// nothing else. The glossy pixels are queued first (`glossy_pixels`; shared/pixel_queue.wgsl):
// run over every pixel, `main` cost two thirds of the pass on `sphere-room-glossy` at 320x240
// for the pixels that were not glossy. CPU twin: `cubetrace::cpu::cone::cone_pixel` (op for op; within the device's acos, tan,
// asin and log2).
//
// Per glossy pixel (G-buffer normal w = -1 - p, p < 1024), with the cone's half-angle theta from
// `lobe_cone_angle(p)` (Eq. 4.1 at xi = 0.244) around the record's axis ray:
// - Hit (the record's exact, verified hit P at distance t from the mirror point; also the hits
//   the reflector check or the fallback found): the CMO k that sees P (the nearest centre whose
//   texel towards P is not nearer than |P - C_k| (1 - 4 / N), i.e. no surface a few texels in
//   front of P from C_k); none: the exact colour stays. The cone's radius at P is
//   rho = t tan(theta), seen from C_k under tan = rho / |P - C_k|, which gives the level
//   (`cone_footprint_level`: the cube's texels shrink in angle towards a face's corners).
//   Occlusion (the 2x2 [min, max] pyramid along the footprint): the level is capped at the
//   finest level whose cell around P's direction has a min distance in front of
//   |P - C_k| - rho (something in front of the hit, beyond the cone's own depth, is inside the
//   footprint: its colour would leak into the filtered colour although, seen from the mirror,
//   it may not be in the cone), i.e. the level used is the coarsest one with no such surface.
//   Colour: exact + (filtered - exact) w, w = clamp(level, 0, 1): level <= 0 is exactly the
//   record's colour.
// - Escaped: the direction-only lookup around the axis in the CMO nearest to the mirror point
//   (`cone_footprint_level` at tan(theta)), blended from the background by the same w.
// - Unresolved (the fallback was not `trace`): left alone.
// - Below the surface: the part of the cone below the reflector's plane is absorbed (as the
//   reference's lobe samples are): the colour is scaled by 1 - f, f = clamp((theta - beta) /
//   (2 theta), 0, 1/2), beta the axis's elevation above the plane (asin(r . n); r . n from the
//   camera ray d and the axis r alone: (r . n)^2 = (1 - d . r) / 2 for a mirror reflection).
//! import shared/cone.wgsl
//! import shared/pixel_queue.wgsl

// The specular power of pixel `i` where the pass shades it (a reflector with p < 1024), else -1.
fn cone_power(i: u32) -> f32 {
    let pixel = vec2<i32>(i32(i % frame.width), i32(i / frame.width));
    if textureLoad(gbuffer_position, pixel, 0).w != 1.0 {
        return -1.0;
    }
    let power = lobe_gbuffer_power(textureLoad(gbuffer_normal, pixel, 0).w);
    if power < 0.0 || power >= 1024.0 {
        return -1.0;
    }
    return power;
}

// Queues the glossy pixels, one invocation per pixel.
@compute @workgroup_size(64)
fn glossy_pixels(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = pixel_queue_pixel(gid, groups, frame.width * frame.height);
    if i == 0xffffffffu {
        return;
    }
    if cone_power(i) >= 0.0 {
        pixel_queue_push(i);
    }
}

// The level of the axis hit at distance `dist` from CMO k's centre along `u`, capped by the
// pyramid (see the header): the coarsest level <= `level`'s ceiling whose cell has no surface
// in front of `dist - rho`. Level 0 (the texel) is never capped.
fn cone_visible_level(k: u32, u: vec3<f32>, dist: f32, rho: f32, level: f32) -> f32 {
    let size = trace_config.size;
    let top = cone_top(size);
    var lv = level;
    if lv <= 0.0 {
        return lv;
    }
    var l = top;
    let c = ceil(lv);
    if c < f32(top) {
        l = u32(c);
    }
    let texel = dir_to_texel(u, size);
    let front = dist - rho;
    let len = cone_len(size);
    while l > 0u {
        let at = cone_level_at(size, l);
        let w = at.y;
        let cell = cmo_mip[k * len + at.x + (texel.face * w + (texel.y >> l)) * w + (texel.x >> l)];
        if cell.x >= front {
            break;
        }
        lv = min(lv, f32(l - 1u));
        l -= 1u;
    }
    return lv;
}

// `cone_blend`: a + (b - a) clamp(level, 0, 1).
fn cone_blend(a: vec3<f32>, b: vec3<f32>, level: f32) -> vec3<f32> {
    var w = level;
    if w < 0.0 {
        w = 0.0;
    } else if w > 1.0 {
        w = 1.0;
    }
    return a + (b - a) * w;
}

// The CMO that sees the point p (see the header), or 0xffffffff.
fn cone_seeing_cmo(p: vec3<f32>) -> u32 {
    let size = trace_config.size;
    let keep = 1.0 - 4.0 / f32(size);
    var best = 0xffffffffu;
    var best_d = f32_inf();
    for (var k = 0u; k < trace_config.cmo_count; k++) {
        let u = p - cmo_centres[k].xyz;
        let dist = length_glam(u);
        if dist > 0.0 && dist < best_d {
            let d = distance_at(k, dir_to_texel(u, size));
            if is_finite_f32(d) && d >= dist * keep {
                best = k;
                best_d = dist;
            }
        }
    }
    return best;
}

// The fraction of the cone of half-angle `theta` around r kept above the reflector's plane.
fn cone_above(d: vec3<f32>, r: vec3<f32>, theta: f32) -> f32 {
    let c2 = (1.0 - dot_glam(d, r)) * 0.5;
    let beta = asin(sqrt(max(c2, 0.0)));
    var f = (theta - beta) / (2.0 * theta);
    if f < 0.0 {
        f = 0.0;
    } else if f > 0.5 {
        f = 0.5;
    }
    return 1.0 - f;
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = pixel_queue_at(gid, groups);
    if i == 0xffffffffu {
        return;
    }
    let power = cone_power(i);
    let rec = records[i];
    let theta = lobe_cone_angle(power);
    let tan_t = tan(theta);
    let size = trace_config.size;
    var colour = rec.colour;
    if rec.status == RECORD_HIT {
        let k = cone_seeing_cmo(rec.point);
        if k != 0xffffffffu {
            let u = rec.point - cmo_centres[k].xyz;
            let dist = length_glam(u);
            let rho = length_glam(rec.point - rec.origin) * tan_t;
            let level = cone_footprint_level(size, u, rho / dist);
            let lv = cone_visible_level(k, u, dist, rho, level);
            colour = cone_blend(rec.colour, cone_cube_colour(k, u, lv, frame.background), lv);
        }
    } else if rec.status == RECORD_ESCAPED {
        let k = nearest_cmo(rec.origin);
        let level = cone_footprint_level(size, rec.dir, tan_t);
        colour = cone_blend(rec.colour, cone_cube_colour(k, rec.dir, level, frame.background), level);
    } else {
        return;
    }
    let d = normalize_glam(rec.origin - frame.eye);
    records[i].colour = colour * cone_above(d, rec.dir, theta);
}
