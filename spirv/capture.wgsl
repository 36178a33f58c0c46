// capture: rasterises the scene into the faces of cubemap objects (CMOs), a face in one or more
// draws.
//
// Draw `instance_index = k` renders part of a face, `capture_views[k]` (its CMO's centre, its
// face, its part of the face's triangle list), into that face's layer of the colour and distance
// images. The projection is the cube face itself: the vertex's
// CMO-local position in the face's local frame `l = (sc, tc, |ma|)` (src/cubemap/face.rs, the
// Vulkan cube map face selection) goes to clip space as `(l.x, l.y, z, l.z)`, so that pixel
// (x, y) of the face, centre at ((x + 0.5) / N, (y + 0.5) / N) in (s, t), sees exactly the
// direction of texel (x, y) (framebuffer row 0 is t = 0; naga does not flip y here).
//
// Stored per texel: the shaded colour (alpha 1) and the world distance from the CMO centre to the
// surface point, `length(world - centre)` of the perspective-correctly interpolated world
// position: the distance to where the texel's centre ray meets the triangle. Depth only picks the
// nearest surface: reversed depth `z / w = near / l.z` (test GREATER, no far plane), which falls
// with l.z and so, along one texel ray, with the distance; f32 keeps its relative precision at
// every distance. Geometry nearer than `near` along the face axis is clipped.
// `fs_self` also writes the unit normal and the mirror flag: only when some reflector of the scene
// sees itself (model only what the scene needs). Which reflectors are drawn is decided per object
// (`GpuObject.captured`, Scene::self_capture).
// A face's draws cover only its own triangles: its list in `capture_triangles`, global triangle
// indices in increasing order (`WorldGeometry::triangles` order, the index buffer's), made on the
// CPU (`vk::passes::capture::face_triangles`: the objects the capture shows, less the triangles
// proven outside the face), cut into consecutive runs, one per draw, drawn in order. Vertex `v`
// of draw k is corner `v % 3` of triangle `capture_triangles[first + v / 3]` of its view.
// The varyings are packed into four locations (the uv into the world position's and the normal's
// w, the three flat indices into one vector): lavapipe's vertex stage moves every location of
// every vertex, and its capture of a dense scene took about a tenth longer with the eight.
// The `_ids` entry points also write the triangle ID: the global index of the triangle the texel's
// centre ray sees, as a u32 target cleared to u32::MAX. The `_ids_only` ones leave the colour
// out, for frames whose methods shade at verified hits instead.

// The scene's bind group (shared/scene.wgsl).
const SCENE_GROUP: u32 = 0u;
//! import shared/scene.wgsl
//! import shared/cube.wgsl
//! import shared/capture_view.wgsl

@group(1) @binding(0) var<storage, read> capture_views: array<CaptureView>;
@group(1) @binding(1) var<storage, read> capture_triangles: array<u32>;

struct CaptureVarying {
    @builtin(position) clip: vec4<f32>,
    // xyz: the world position; w: u.
    @location(0) world_u: vec4<f32>,
    // xyz: the vertex normal; w: v.
    @location(1) normal_v: vec4<f32>,
    @location(2) colour: vec3<f32>,
    // The object, the view and the triangle.
    @location(3) @interpolate(flat) ids: vec3<u32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) view: u32) -> CaptureVarying {
    let cv = capture_views[view];
    let triangle = capture_triangles[cv.first + vertex / 3u];
    var out: CaptureVarying;
    // A triangle whose plane passes through the centre is seen edge-on (shared/eye_plane.wgsl,
    // marked by `capture_mark.wgsl`): its three vertices go to one point outside the clip
    // volume, so it is culled.
    if triangle == CAPTURE_EDGE_ON {
        out.clip = vec4<f32>(2.0, 2.0, 0.0, 1.0);
        return out;
    }
    let v = scene_vertices[scene_indices[3u * triangle + vertex % 3u]];
    let l = to_face_local(cv.face, v.position - cv.centre);
    out.clip = vec4<f32>(l.x, l.y, cv.near, l.z);
    out.world_u = vec4<f32>(v.position, v.uv.x);
    out.normal_v = vec4<f32>(v.normal, v.uv.y);
    out.colour = scene_vertex_colour(v);
    out.ids = vec3<u32>(v.object, view, triangle);
    return out;
}

struct CaptureOut {
    @location(0) colour: vec4<f32>,
    @location(1) distance: f32,
}

struct CaptureSelfOut {
    @location(0) colour: vec4<f32>,
    @location(1) distance: f32,
    // Unit normal, w = 1 on a reflector.
    @location(2) normal_mirror: vec4<f32>,
}

fn capture_distance(in: CaptureVarying) -> f32 {
    return length(in.world_u.xyz - capture_views[in.ids.y].centre);
}

// The shaded colour, alpha 1.
fn capture_shade(in: CaptureVarying) -> vec4<f32> {
    let uv = vec2<f32>(in.world_u.w, in.normal_v.w);
    return vec4<f32>(scene_shade(in.ids.x, uv, in.normal_v.xyz, in.colour), 1.0);
}

@fragment
fn fs_main(in: CaptureVarying) -> CaptureOut {
    return CaptureOut(capture_shade(in), capture_distance(in));
}

// With self-reflections a reflector is captured only where it faces the CMO centre (its normal,
// turned to its front by `scene_front_normal`, points towards the centre). A CMO sits inside or near its reflector; the reflector's far side
// would otherwise hide the whole scene from it, and every ray leaving the reflector would start
// behind its own surface. A reflected ray leaves the surface along the outward side, so the
// reflector parts it can meet face back towards the reflector, and so towards the centre.
@fragment
fn fs_self(in: CaptureVarying) -> CaptureSelfOut {
    if !capture_self_keeps(in) {
        discard;
    }
    return CaptureSelfOut(capture_shade(in), capture_distance(in), capture_normal_mirror(in));
}

// Whether the fragment is kept with self-reflections on (`fs_self`'s test).
fn capture_self_keeps(in: CaptureVarying) -> bool {
    let towards = in.world_u.xyz - capture_views[in.ids.y].centre;
    return !(scene_is_reflector(in.ids.x) && dot(scene_front_normal(in.ids.x, in.normal_v.xyz), towards) > 0.0);
}

fn capture_normal_mirror(in: CaptureVarying) -> vec4<f32> {
    return vec4<f32>(scene_normalize(in.normal_v.xyz), select(0.0, 1.0, scene_is_reflector(in.ids.x)));
}

struct CaptureIdsOut {
    @location(0) colour: vec4<f32>,
    @location(1) distance: f32,
    @location(2) triangle: u32,
}

@fragment
fn fs_main_ids(in: CaptureVarying) -> CaptureIdsOut {
    return CaptureIdsOut(capture_shade(in), capture_distance(in), in.ids.z);
}

struct CaptureSelfIdsOut {
    @location(0) colour: vec4<f32>,
    @location(1) distance: f32,
    @location(2) normal_mirror: vec4<f32>,
    @location(3) triangle: u32,
}

@fragment
fn fs_self_ids(in: CaptureVarying) -> CaptureSelfIdsOut {
    if !capture_self_keeps(in) {
        discard;
    }
    return CaptureSelfIdsOut(
        capture_shade(in),
        capture_distance(in),
        capture_normal_mirror(in),
        in.ids.z,
    );
}

struct CaptureIdsOnlyOut {
    @location(0) distance: f32,
    @location(1) triangle: u32,
}

@fragment
fn fs_ids_only(in: CaptureVarying) -> CaptureIdsOnlyOut {
    return CaptureIdsOnlyOut(capture_distance(in), in.ids.z);
}

struct CaptureSelfIdsOnlyOut {
    @location(0) distance: f32,
    @location(1) normal_mirror: vec4<f32>,
    @location(2) triangle: u32,
}

@fragment
fn fs_self_ids_only(in: CaptureVarying) -> CaptureSelfIdsOnlyOut {
    if !capture_self_keeps(in) {
        discard;
    }
    return CaptureSelfIdsOnlyOut(capture_distance(in), capture_normal_mirror(in), in.ids.z);
}
