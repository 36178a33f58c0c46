// ssr: Hi-Z screen-space reflections (Uludag 2014, "Hi-Z Screen-Space Cone-Traced Reflections",
// GPU Pro 5), the mirror (non-glossy) part: the Hi-Z traversal of Listing 4.2 / 4.5 over the
// pyramid of the `ssr_hiz` pass. A deferred full-screen fragment pass; every mirror pixel writes its
// record. CPU twin: `cubetrace::cpu::ssr::trace` (same loop, same arithmetic).
//
// Screen space: x, y in pixels (pixel (i, j) covers [i, i + 1) x [j, j + 1)), z the depth key q of
// shared/ssr.wgsl. The ray is `o + d t` with `d.z = 1`, so `t` is the depth key itself, and `o`
// the point where q = 0 (the ray's vanishing point), as the chapter sets `d.z = 1` and puts `o`
// at depth 0.
//
// Record fields as this pass writes them: `status` hit or unresolved (never escaped: screen
// space cannot tell an escaped ray from one that left the screen); `x`, `y` the pixel the ray
// landed on (hit) or was in when it stopped; `point` and `colour` the G-buffer's world position
// and colour of the hit pixel; `cells` the loop iterations; `face` the outcome (SSR_* below);
// `t` the ray's depth key at the end; `cmo` 0xffffffff (no CMO decides); `texels`, `traces`,
// `riser`, `t_done` 0.
//! import shared/mirror.wgsl
//! import shared/ssr.wgsl

@group(0) @binding(4) var gbuffer_colour: texture_2d<f32>;
@group(0) @binding(5) var<storage, read> hiz: array<f32>;
@group(0) @binding(6) var<storage, read> ssr: SsrParams;

// Outcomes (`cpu::ssr::Outcome`).
const SSR_HIT: u32 = 0u;
// The ray goes towards the camera or parallel to the screen: a min pyramid cannot trace it
// (section 4.6.7).
const SSR_TOWARDS_CAMERA: u32 = 1u;
// The ray left the screen (or reached infinite depth).
const SSR_OFF_SCREEN: u32 = 2u;
// The iteration cap was reached.
const SSR_ITERATIONS: u32 = 3u;
// The hit lies more than the thickness behind the surface.
const SSR_THICKNESS: u32 = 4u;
// The ray landed on a pixel where nothing was drawn.
const SSR_NO_SURFACE: u32 = 5u;

const SSR_FAR: f32 = 3.4028235e38;

fn hiz_at(level: i32, cell: vec2<i32>) -> f32 {
    let l = ssr.levels[u32(level)];
    return hiz[l.x + u32(cell.y) * l.y + u32(cell.x)];
}

// Clamped before the conversion (an out-of-range float to int conversion is undefined in
// SPIR-V); +-2^24 pixels is far off any screen.
const SSR_CLAMP: f32 = 16777216.0;

fn cell_of(p: vec2<f32>, level: i32) -> vec2<i32> {
    let size = f32(1u << u32(level));
    return vec2<i32>(floor(clamp(p, vec2<f32>(-SSR_CLAMP), vec2<f32>(SSR_CLAMP)) / size));
}

fn on_screen(ray: vec3<f32>) -> bool {
    return ray.x >= 0.0 && ray.x < f32(ssr.width) && ray.y >= 0.0 && ray.y < f32(ssr.height)
        && ray.z < 0.0;
}

// The chapter's `intersectCellBoundary`: where the ray leaves `cell` of `level` (plus the
// crossing offset), as `o + d t`.
fn cross_cell(o: vec3<f32>, d: vec3<f32>, cell: vec2<i32>, level: i32, step: vec2<f32>,
              offset: vec2<f32>) -> vec3<f32> {
    let size = f32(1u << u32(level));
    let boundary = (vec2<f32>(cell) + step) * size + offset;
    var tx = SSR_FAR;
    if d.x != 0.0 {
        tx = (boundary.x - o.x) / d.x;
    }
    var ty = SSR_FAR;
    if d.y != 0.0 {
        ty = (boundary.y - o.y) / d.y;
    }
    let t = min(tx, ty);
    return o + d * t;
}

struct SsrResult {
    outcome: u32,
    pixel: vec2<i32>,
    iterations: u32,
    t: f32,
}

fn ssr_trace(pixel: vec2<u32>, origin: vec3<f32>, dir: vec3<f32>) -> SsrResult {
    let w = f32(ssr.width);
    let h = f32(ssr.height);
    // Screen-space direction: the derivative of (pixel x, pixel y, q) along the world ray,
    // times c0.w^2 (only its direction matters).
    let c0 = ssr_clip(ssr.view_proj, origin, 1.0);
    let c1 = ssr_clip(ssr.view_proj, dir, 0.0);
    let v = vec3<f32>(
        (0.5 * w) * (c1.x * c0.w - c0.x * c1.w),
        (0.5 * h) * (c1.y * c0.w - c0.y * c1.w),
        c1.w,
    );
    let here = vec2<i32>(pixel);
    if !(v.z > 0.0) {
        return SsrResult(SSR_TOWARDS_CAMERA, here, 0u, hiz_at(0, here));
    }
    let p = vec3<f32>(vec2<f32>(pixel) + 0.5, hiz_at(0, here));
    let d = v / v.z;
    let o = p - d * p.z;
    let step = vec2<f32>(select(0.0, 1.0, d.x >= 0.0), select(0.0, 1.0, d.y >= 0.0));
    let offset = vec2<f32>(select(-1.0, 1.0, d.x >= 0.0), select(-1.0, 1.0, d.y >= 0.0))
        * ssr.cross_epsilon;
    let max_level = i32(ssr.level_count) - 1;
    // Cross into the next cell first, so that the ray does not hit its own pixel.
    var ray = cross_cell(o, d, here, 0, step, offset);
    var level = 0;
    var iterations = 0u;
    while level >= 0 && iterations < ssr.max_iterations {
        if !on_screen(ray) {
            break;
        }
        let old_cell = cell_of(ray.xy, level);
        let min_z = hiz_at(level, old_cell);
        var next = o + d * max(ray.z, min_z);
        let new_cell = cell_of(next.xy, level);
        if any(new_cell != old_cell) {
            next = cross_cell(o, d, old_cell, level, step, offset);
            level = min(max_level, level + 2);
        }
        ray = next;
        level -= 1;
        iterations += 1u;
    }
    let last = cell_of(ray.xy, 0);
    if !on_screen(ray) {
        return SsrResult(SSR_OFF_SCREEN, last, iterations, ray.z);
    }
    if level >= 0 {
        return SsrResult(SSR_ITERATIONS, last, iterations, ray.z);
    }
    let surface = hiz_at(0, last);
    if surface == 0.0 {
        return SsrResult(SSR_NO_SURFACE, last, iterations, ray.z);
    }
    if ssr.thickness_on != 0u && (-1.0 / ray.z) - (-1.0 / surface) > ssr.thickness {
        return SsrResult(SSR_THICKNESS, last, iterations, ray.z);
    }
    return SsrResult(SSR_HIT, last, iterations, ray.z);
}

@fragment
fn fs_main(@builtin(position) position: vec4<f32>) {
    let pixel = vec2<u32>(position.xy);
    let ray = mirror_ray(pixel);
    if !ray.mirror {
        return;
    }
    let r = ssr_trace(pixel, ray.origin, ray.dir);
    var status = RECORD_UNRESOLVED;
    var point = ray.origin;
    var colour = frame.background;
    if r.outcome == SSR_HIT {
        status = RECORD_HIT;
        point = textureLoad(gbuffer_position, r.pixel, 0).xyz;
        colour = textureLoad(gbuffer_colour, r.pixel, 0).xyz;
    }
    records[pixel.y * frame.width + pixel.x] = PixelRecord(
        ray.origin, status, ray.dir, 0xffffffffu, point, 0u, colour,
        r.outcome, u32(r.pixel.x), u32(r.pixel.y), 0u, r.iterations, 0u, r.t, 0.0, 0xffffffffu, 0u, 0u, 1u, 0u,
    );
}
