// gbuffer: the camera's view of the scene, deferred: what the tracing passes start from.
//
// Per pixel: the shaded colour (alpha 1 where a surface is seen), the world position of the
// surface, where the pixel-centre ray meets the triangle's plane (`fs_main`; w = 1 where it is a
// reflector: the mirror mask; 0 on other surfaces; -1, the clear value, where nothing is drawn),
// and the vertex normal interpolated there as
// stored (w = 1 where covered, but on a glossy reflector, where w = -1 - its Phong specular
// power: at most -1, read with `lobe_gbuffer_power` in shared/lobe.wgsl; 0 where nothing is
// drawn), and the global index of the triangle seen (`vertex_index / 3`:
// the draw is of every triangle in `WorldGeometry::triangles` order; u32::MAX, the clear value,
// where nothing is drawn), which the BVH tracer's start rule reads. The mirror's normal is left unnormalised here; tracers normalise
// it exactly as the CPU reference does (`normalize_or_zero` of the interpolated normal).

// The scene's bind group (shared/scene.wgsl).
const SCENE_GROUP: u32 = 0u;
//! import shared/scene.wgsl
//! import shared/camera.wgsl
//! import shared/eye_plane.wgsl

struct GbufferCamera {
    view_proj: mat4x4<f32>,
    // `Camera::ray`'s inputs, as the CPU computes them: the eye, the basis, tan(fov_y / 2), the
    // aspect ratio and the frame size.
    eye: vec3<f32>,
    tan_half: f32,
    right: vec3<f32>,
    aspect: f32,
    up: vec3<f32>,
    width: f32,
    back: vec3<f32>,
    height: f32,
    // `Camera::jitter` (pixels): `view_proj` moves the image by `-jitter`, so that the pixel
    // centre sees the sample's ray.
    jitter: vec2<f32>,
    pad: vec2<f32>,
}

@group(1) @binding(0) var<uniform> gbuffer_camera: GbufferCamera;

struct GbufferVarying {
    @builtin(position) clip: vec4<f32>,
    // xyz: the world position; w: u (the varyings packed as the capture's: spirv/capture.wgsl).
    @location(0) world_u: vec4<f32>,
    // xyz: the vertex normal; w: v.
    @location(1) normal_v: vec4<f32>,
    @location(2) colour: vec3<f32>,
    // The object and the triangle.
    @location(3) @interpolate(flat) ids: vec2<u32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32) -> GbufferVarying {
    let v = scene_vertices[scene_indices[vertex]];
    var out: GbufferVarying;
    out.clip = gbuffer_camera.view_proj * vec4<f32>(v.position, 1.0);
    // A triangle whose plane passes through the eye is seen edge-on (shared/eye_plane.wgsl):
    // all three vertices go to one point outside the clip volume, and it covers no pixel.
    let t = 3u * (vertex / 3u);
    let a = scene_vertices[scene_indices[t]].position;
    let b = scene_vertices[scene_indices[t + 1u]].position;
    let c = scene_vertices[scene_indices[t + 2u]].position;
    if eye_plane_holds(gbuffer_camera.eye, a, b, c) {
        out.clip = vec4<f32>(2.0, 2.0, 0.0, 1.0);
    }
    out.world_u = vec4<f32>(v.position, v.uv.x);
    out.normal_v = vec4<f32>(v.normal, v.uv.y);
    out.colour = scene_vertex_colour(v);
    out.ids = vec2<u32>(v.object, vertex / 3u);
    return out;
}

struct GbufferOut {
    @location(0) colour: vec4<f32>,
    @location(1) position_mirror: vec4<f32>,
    @location(2) normal: vec4<f32>,
    @location(3) triangle: u32,
}

// Where the ray `o + t d` meets the plane of (a, b, c): `(t, u, v)`, the barycentric weights of b
// and c (Möller–Trumbore as `reference::intersect`, in f32 and without the edge tests: a pixel
// centre the rasteriser gave this triangle may lie a snapping error outside it, and the plane's
// point is then the better start). `t` is NaN or not positive where the ray misses the plane.
fn gbuffer_plane_hit(o: vec3<f32>, d: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    let e1 = b - a;
    let e2 = c - a;
    let p = cross(d, e2);
    let det = dot(e1, p);
    let inv = 1.0 / det;
    let s = o - a;
    let q = cross(s, e1);
    return vec3<f32>(dot(e2, q) * inv, dot(s, p) * inv, dot(d, q) * inv);
}

@fragment
fn fs_main(in: GbufferVarying) -> GbufferOut {
    // The rasteriser interpolates the attributes from vertices snapped to its sub-pixel grid, so
    // they stray from the pixel-centre ray by up to that grid's step. The reference's primary
    // hit lies on the ray: recompute the hit on this triangle with the reference's ray and
    // interpolate with its barycentrics. Where that fails (a ray in the triangle's plane, or a
    // centre a quarter of the triangle outside it, which only a sub-pixel sliver gives), the
    // rasteriser's values stay.
    let pixel = vec2<u32>(in.clip.xy);
    let c = gbuffer_camera;
    let o = c.eye;
    let d = camera_ray_dir(pixel, c.jitter, c.width, c.height, c.tan_half, c.aspect, c.right, c.up, c.back);
    let v0 = scene_vertices[scene_indices[3u * in.ids.y]];
    let v1 = scene_vertices[scene_indices[3u * in.ids.y + 1u]];
    let v2 = scene_vertices[scene_indices[3u * in.ids.y + 2u]];
    let h = gbuffer_plane_hit(o, d, v0.position, v1.position, v2.position);
    var world = in.world_u.xyz;
    var normal = in.normal_v.xyz;
    var uv = vec2<f32>(in.world_u.w, in.normal_v.w);
    var colour = in.colour;
    let u = h.y;
    let v = h.z;
    let w = 1.0 - u - v;
    if h.x > 0.0 && h.x < bitcast<f32>(0x7f800000u) && min(min(u, v), w) > -0.25 {
        world = o + d * h.x;
        normal = v0.normal * w + v1.normal * u + v2.normal * v;
        uv = v0.uv * w + v1.uv * u + v2.uv * v;
        colour = scene_vertex_colour(v0) * w + scene_vertex_colour(v1) * u + scene_vertex_colour(v2) * v;
    }
    let mirror = select(0.0, 1.0, scene_is_reflector(in.ids.x));
    // A glossy reflector's specular power p goes into the normal's w as -1 - p (at most -1; see
    // the header); every other covered pixel keeps 1.
    let power = scene_objects[in.ids.x].specular_power;
    let normal_w = select(1.0, -1.0 - power, power >= 0.0);
    return GbufferOut(
        vec4<f32>(scene_shade(in.ids.x, uv, normal, colour), 1.0),
        vec4<f32>(world, mirror),
        vec4<f32>(normal, normal_w),
        in.ids.y,
    );
}
