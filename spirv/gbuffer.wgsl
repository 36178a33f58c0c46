// gbuffer: the camera's view of the scene, deferred: what the tracing passes start from.
//
// Per pixel: the shaded colour (alpha 1 where a surface is seen), the world position of the
// surface (w = 1 where it is a reflector: the mirror mask; 0 on other surfaces; -1, the clear value,
// where nothing is drawn), and the interpolated vertex normal as
// stored (w = 1 where covered), and the global index of the triangle seen (`vertex_index / 3`:
// the draw is of every triangle in `WorldGeometry::triangles` order; u32::MAX, the clear value,
// where nothing is drawn), which the BVH tracer's start rule reads. The mirror's normal is left unnormalised here; tracers normalise
// it exactly as the CPU reference does (`normalize_or_zero` of the interpolated normal).

// The scene's bind group (shared/scene.wgsl).
const SCENE_GROUP: u32 = 0u;
//! import shared/scene.wgsl

struct GbufferCamera {
    view_proj: mat4x4<f32>,
}

@group(1) @binding(0) var<uniform> gbuffer_camera: GbufferCamera;

struct GbufferVarying {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) @interpolate(flat) object: u32,
    @location(4) @interpolate(flat) triangle: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32) -> GbufferVarying {
    let v = scene_vertices[scene_indices[vertex]];
    var out: GbufferVarying;
    out.clip = gbuffer_camera.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.uv = v.uv;
    out.object = v.object;
    out.triangle = vertex / 3u;
    return out;
}

struct GbufferOut {
    @location(0) colour: vec4<f32>,
    @location(1) position_mirror: vec4<f32>,
    @location(2) normal: vec4<f32>,
    @location(3) triangle: u32,
}

@fragment
fn fs_main(in: GbufferVarying) -> GbufferOut {
    let mirror = select(0.0, 1.0, scene_is_reflector(in.object));
    return GbufferOut(
        vec4<f32>(scene_shade(in.object, in.uv, in.normal), 1.0),
        vec4<f32>(in.world, mirror),
        vec4<f32>(in.normal, 1.0),
        in.triangle,
    );
}
