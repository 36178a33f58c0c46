// reflection_point_raster: the virtual objects of the reflection-point method (Estalella et al. 2006,
// section 3), then one record per mirror pixel.
//
// - `vs_virtual` / `fs_virtual`: every non-reflector triangle drawn at its virtual vertices
//   (from `reflection_point_search`), with reversed depth of the reflected path's length, into the reflector's pixels only: the fragment
//   shader discards pixels where the G-buffer's mirror mask is not set (the paper's stencil).
//   A triangle with a vertex whose search gave no virtual vertex (cap, no reflector on screen)
//   is dropped. The colour is the shared shading at the original vertex attributes
//   (interpolated across the virtual triangle), so colour differences are geometric, with the
//   object's index in alpha; the second target is the original surface point (w = 1 where
//   covered).
// - `resolve`: per mirror pixel, a hit record (point = the original surface point, colour)
//   and `face` = the object's index) where a virtual object covers it, else an unresolved record
//   (the frame's fallback fills it). `cmo` is 0xffffffff; `texels`, `cells`, `traces`, `riser`,
//   `t`, `t_done` are 0 (the search's counts are per vertex, read from `reflection_point_search`'s buffer).

// The scene's bind group (shared/scene.wgsl).
const SCENE_GROUP: u32 = 0u;
//! import shared/scene.wgsl
//! import shared/record.wgsl

struct RpCamera {
    view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    // The camera's near plane (the reversed depth's `near / distance`).
    near: f32,
}

// `RpVertex` of reflection_point_search.wgsl.
struct RpVertex {
    position: vec3<f32>,
    status: u32,
    texel: vec2<i32>,
    iterations: u32,
    inverse_iterations: u32,
    path: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

const RP_FOUND: u32 = 1u;
const RP_HIDDEN: u32 = 2u;

@group(1) @binding(0) var<uniform> rp_camera: RpCamera;
@group(1) @binding(1) var<storage, read> rp_vertices: array<RpVertex>;
@group(1) @binding(2) var gbuffer_position: texture_2d<f32>;

fn rp_has_virtual(index: u32) -> bool {
    let s = rp_vertices[index].status;
    return s == RP_FOUND || s == RP_HIDDEN;
}

struct VirtualVarying {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) @interpolate(flat) object: u32,
    @location(4) colour: vec3<f32>,
}

@vertex
fn vs_virtual(@builtin(vertex_index) vertex: u32) -> VirtualVarying {
    let index = scene_indices[vertex];
    let v = scene_vertices[index];
    let first = vertex - vertex % 3u;
    let keep = !scene_is_reflector(v.object) && rp_has_virtual(scene_indices[first])
        && rp_has_virtual(scene_indices[first + 1u]) && rp_has_virtual(scene_indices[first + 2u]);
    var out: VirtualVarying;
    var clip = rp_camera.view_proj * vec4<f32>(rp_vertices[index].position, 1.0);
    // Depth: the reflected path's length, not the virtual vertex's own depth. They agree for a
    // vertex in front of its reflection point's plane (the mirror image lies on the eye ray at
    // that distance); a hidden vertex's image from the inverse search lies in front of the
    // mirror and would otherwise hide the true reflections near the outline.
    clip.z = clip.w * rp_camera.near / max(rp_vertices[index].path, rp_camera.near);
    out.clip = select(vec4<f32>(2.0, 2.0, 0.5, 1.0), clip, keep);
    out.world = v.position;
    out.normal = v.normal;
    out.uv = v.uv;
    out.colour = scene_vertex_colour(v);
    out.object = v.object;
    return out;
}

struct VirtualOut {
    @location(0) colour: vec4<f32>,
    @location(1) point: vec4<f32>,
}

@fragment
fn fs_virtual(in: VirtualVarying) -> VirtualOut {
    let pixel = vec2<i32>(floor(in.clip.xy));
    if textureLoad(gbuffer_position, pixel, 0).w != 1.0 {
        discard;
    }
    return VirtualOut(
        vec4<f32>(scene_shade(in.object, in.uv, in.normal, in.colour), f32(in.object)),
        vec4<f32>(in.world, 1.0),
    );
}


// Bindings 8.. of group 0, apart from the scene's 0..7 (the virtual draw's).
@group(0) @binding(8) var<uniform> rp_resolve_camera: RpCamera;
@group(0) @binding(9) var resolve_position: texture_2d<f32>;
@group(0) @binding(10) var resolve_normal: texture_2d<f32>;
@group(0) @binding(11) var virtual_colour: texture_2d<f32>;
@group(0) @binding(12) var virtual_point: texture_2d<f32>;
@group(0) @binding(13) var<storage, read_write> records: array<PixelRecord>;

@compute @workgroup_size(64)
fn resolve(@builtin(global_invocation_id) gid: vec3<u32>) {
    let dims = textureDimensions(resolve_position);
    let i = gid.x;
    if i >= dims.x * dims.y {
        return;
    }
    let pixel = vec2<i32>(vec2<u32>(i % dims.x, i / dims.x));
    let p = textureLoad(resolve_position, pixel, 0);
    if p.w != 1.0 {
        return;
    }
    // The mirror ray (for the fallback's environment-map lookup), as shared/mirror.wgsl.
    let n = scene_normalize(textureLoad(resolve_normal, pixel, 0).xyz);
    let d = scene_normalize(p.xyz - rp_resolve_camera.eye);
    let dn = d.x * n.x + d.y * n.y + d.z * n.z;
    let dir = scene_normalize(d - n * (2.0 * dn));
    let c = textureLoad(virtual_colour, pixel, 0);
    let q = textureLoad(virtual_point, pixel, 0);
    var r: PixelRecord;
    r.origin = p.xyz;
    r.dir = dir;
    r.cmo = 0xffffffffu;
    r.triangle = 0xffffffffu;
    r.x = u32(pixel.x);
    r.y = u32(pixel.y);
    r.bounces = 1u;
    if q.w == 1.0 {
        r.status = RECORD_HIT;
        r.point = q.xyz;
        r.colour = c.xyz;
        r.face = u32(c.w);
    } else {
        r.status = RECORD_UNRESOLVED;
        r.point = p.xyz;
    }
    records[i] = r;
}
