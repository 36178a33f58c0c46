// ssr_cone: the cone-tracing pass (section 4.4.5, Listing 4.7), after `ssr`'s Hi-Z trace, one
// invocation per glossy pixel whose ray hit; it rewrites the colour of their records. Those
// pixels are queued first (`cone_pixels`; shared/pixel_queue.wgsl).
// CPU twin: `cubetrace::cpu::ssr_cone::cone_colour` (same loop and arithmetic; the device's tan,
// acos, exp2 and log2 differ from Rust's by a few ulp, hence the twin's tolerance).
//
// The cone: half-angle `lobe_cone_angle(power)` (Eq. 4.1, xi = 0.244). In screen space it is
// the isosceles triangle from the ray's start P1 (the pixel centre) to its hit P2 (the hit
// pixel's centre), of height l = |P2 - P1| and base 2 tan(theta) l (Eq. 4.2). Starting from the
// hit end, as the listing does, each step takes the triangle's in-radius
// r = a (sqrt(a^2 + 4 h^2) - a) / (4 h) (base a, height h), samples the circle at distance
// h - r from P1, and moves on to the triangle of height h - 2 r; SSR_CONE_SAMPLES steps at most
// (the listing's 7). At each circle:
// - colour: trilinear (bilinear in the two levels around m = log2(r), blended), m as the listing
//   computes it (`log2` of the radius in pixels), clamped to the chain's levels;
// - weight: the pre-integrated visibility of the cell under the circle's centre at level
//   floor(m), times how much the cone's sphere there meets that cell's Hi-Z: the sphere of
//   radius R = r pixel footprints around the ray's point (depth key interpolated between the
//   start's and the hit's, which is exact: the key is affine along a screen-space ray) spans the
//   view depths [a, b]; against the cell's [w_min, w_max] (min and max keys) its weight rises
//   from 0 (b <= w_min: in front of everything in the cell) to 1 (a >= w_max: behind everything)
//   linearly in between, (b - w_min) / ((b - a) + (w_max - w_min)).
// Colours and weights accumulate front to back along the walk until the weight reaches 1 (a
// sample takes at most what is left). The rest (1 - accumulated) is the remainder, which the
// chapter blends "from cube maps with the same roughness": `cone_envmap_colour`
// (shared/cone.wgsl), the pre-filtered colour of the CMO nearest to the pixel along the mirror
// direction, at the level of the lobe's cone (direction only: no parallax).
//! import shared/cone.wgsl
//! import shared/mirror.wgsl
//! import shared/lobe.wgsl
//! import shared/ssr.wgsl
//! import shared/ssr_cone.wgsl
//! import shared/pixel_queue.wgsl

@group(0) @binding(4) var<storage, read> hiz: array<f32>;
@group(0) @binding(5) var<storage, read> hiz_max: array<f32>;
@group(0) @binding(6) var<storage, read> visibility: array<f32>;
@group(0) @binding(7) var<storage, read> chain: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> ssr: SsrParams;

const SSR_CONE_SAMPLES: u32 = 7u;

// The specular power of pixel `index` where `main` cone traces it (a glossy reflector whose ray
// hit), else -1.
fn ssr_cone_power(index: u32) -> f32 {
    let pixel = vec2<i32>(i32(index % ssr.width), i32(index / ssr.width));
    if textureLoad(gbuffer_position, pixel, 0).w != 1.0 {
        return -1.0;
    }
    let power = lobe_gbuffer_power(textureLoad(gbuffer_normal, pixel, 0).w);
    if power < 0.0 || records[index].status != RECORD_HIT {
        return -1.0;
    }
    return power;
}

// Queues the pixels `main` cone traces, one invocation per pixel.
@compute @workgroup_size(64)
fn cone_pixels(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let index = pixel_queue_pixel(gid, groups, ssr.width * ssr.height);
    if index == 0xffffffffu {
        return;
    }
    if ssr_cone_power(index) >= 0.0 {
        pixel_queue_push(index);
    }
}

fn level_index(level: u32, cell: vec2<u32>) -> u32 {
    let l = ssr.levels[level];
    return l.x + cell.y * l.y + cell.x;
}

// The cell of `level` under screen position `p` (pixels), clamped to the level.
fn cell_at(p: vec2<f32>, level: u32) -> vec2<u32> {
    let l = ssr.levels[level];
    let size = f32(1u << level);
    let c = floor(clamp(p, vec2<f32>(0.0), vec2<f32>(f32(ssr.width), f32(ssr.height))) / size);
    return vec2<u32>(min(u32(c.x), l.y - 1u), min(u32(c.y), l.z - 1u));
}

// Bilinear colour of `level` at screen position `p` (pixels), taps clamped to the level.
fn chain_bilinear(level: u32, p: vec2<f32>) -> vec3<f32> {
    let l = ssr.levels[level];
    let size = f32(1u << level);
    let c = p / size - 0.5;
    let c0 = floor(c);
    let f = c - c0;
    let x0 = u32(clamp(c0.x, 0.0, f32(l.y - 1u)));
    let x1 = u32(clamp(c0.x + 1.0, 0.0, f32(l.y - 1u)));
    let y0 = u32(clamp(c0.y, 0.0, f32(l.z - 1u)));
    let y1 = u32(clamp(c0.y + 1.0, 0.0, f32(l.z - 1u)));
    let a = chain[l.x + y0 * l.y + x0].xyz;
    let b = chain[l.x + y0 * l.y + x1].xyz;
    let d = chain[l.x + y1 * l.y + x0].xyz;
    let e = chain[l.x + y1 * l.y + x1].xyz;
    let top = a * (1.0 - f.x) + b * f.x;
    let bottom = d * (1.0 - f.x) + e * f.x;
    return top * (1.0 - f.y) + bottom * f.y;
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let index = pixel_queue_at(gid, groups);
    // No barrier in this shader: an early return is uniform-safe.
    if index == 0xffffffffu {
        return;
    }
    let pixel = vec2<u32>(index % ssr.width, index / ssr.width);
    let power = ssr_cone_power(index);
    let rec = records[index];
    let tan_theta = tan(lobe_cone_angle(power));
    let p1 = vec2<f32>(pixel) + 0.5;
    let q1 = hiz[index];
    let p2 = vec2<f32>(f32(rec.x), f32(rec.y)) + 0.5;
    let q2 = rec.t;
    let delta = p2 - p1;
    let len = sqrt(delta.x * delta.x + delta.y * delta.y);
    if !(len > 0.0) {
        return;
    }
    let unit = delta / len;
    // View depth per pixel of radius at view depth 1 (the pixel footprint's slope).
    let footprint = (2.0 * frame.tan_half) / f32(ssr.height);
    let top_level = f32(ssr.level_count - 1u);
    var adjacent = len;
    var colour = vec3<f32>(0.0);
    var weight = 0.0;
    for (var i = 0u; i < SSR_CONE_SAMPLES; i++) {
        let opposite = 2.0 * tan_theta * adjacent;
        let radius = opposite * (sqrt(opposite * opposite + 4.0 * adjacent * adjacent) - opposite)
            / (4.0 * adjacent);
        let along = adjacent - radius;
        let p = p1 + unit * along;
        let q = q1 + (q2 - q1) * (along / len);
        let m = clamp(log2(radius), 0.0, top_level);
        let level = u32(floor(m));
        let upper = min(level + 1u, ssr.level_count - 1u);
        let blend = m - floor(m);
        let c = chain_bilinear(level, p) * (1.0 - blend) + chain_bilinear(upper, p) * blend;
        let k = level_index(level, cell_at(p, level));
        let w_min = ssr_cone_depth(hiz[k]);
        let w_max = ssr_cone_depth(hiz_max[k]);
        let w = ssr_cone_depth(q);
        let sphere = radius * w * footprint;
        let a = w - sphere;
        let b = w + sphere;
        let span = (b - a) + (w_max - w_min);
        var meets = select(0.0, 1.0, w >= w_min);
        if span > 0.0 {
            meets = clamp((b - w_min) / span, 0.0, 1.0);
        }
        let take = min(visibility[k] * meets, 1.0 - weight);
        colour = colour + c * take;
        weight = weight + take;
        if weight >= 1.0 {
            break;
        }
        adjacent = adjacent - 2.0 * radius;
        if !(adjacent > 0.0) {
            break;
        }
    }
    // One call site: lavapipe inlines every call.
    let remainder = cone_envmap_colour(nearest_cmo(rec.origin), rec.dir, power, frame.background);
    records[index].colour = colour + remainder * (1.0 - weight);
}
