// reflection_point_search: the reflection-point search of Estalella et al. 2006 ("A GPU-driven Algorithm for
// Accurate Interactive Reflections on Curved Objects"), sections 4 and 5.1. CPU twin:
// `cubetrace::cpu::reflection_point` (same loop, same arithmetic).
//
// Two parts, both in this pass:
// - `vs_reflector` / `fs_reflector`: the reflectors alone, from the camera, into the textures T_P
//   (world position, w = 1 on a reflector texel, 0 elsewhere) and T_N (interpolated normal).
//   Other objects are not drawn, so they do not hide the reflector from the search. After the
//   scene's triangles come the closing triangles of open reflectors (`cpu::closure`, the paper's
//   closed version), with their own depth, or behind every reflector surface where they cap the
//   mirror's side (a concave mirror's opening).
// - `search`: one invocation per scene vertex. Reflector vertices are skipped. From the start
//   texel, each step scores the centre and its neighbours (the four of the crosshair on the first
//   step, all eight afterwards) by `dot(N, B)`, B the bisector of the directions to the eye and to
//   the vertex, and moves to the best until the centre wins or the iteration cap is reached.
//   Texels off the reflector never win, so the search stops at the reflector's outline when the
//   maximum lies beyond it. If the vertex is behind the plane of the texel found (region C,
//   hidden), the inverse search runs from there: the vertex is taken as the virtual one and the
//   candidate original is its mirror image in the plane of each texel. The virtual vertex is the
//   vertex mirrored in the plane (R, N) of the final texel, and its depth the reflected path's
//   length |O - R| + |R - V|.

// The scene's bind group (shared/scene.wgsl).
const SCENE_GROUP: u32 = 0u;
//! import shared/scene.wgsl

struct RpParams {
    view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    max_iterations: u32,
    // The start texel: the projection of the centre of the reflectors' bounding box, clamped
    // to the frame.
    start: vec2<i32>,
    width: u32,
    height: u32,
    vertex_count: u32,
    // The scene's index count: vertices of the reflector draw past it are closing ones.
    index_count: u32,
    pad1: u32,
    pad2: u32,
}

// `cpu::closure::ClosureVertex`: a closing triangle's vertex (a triangle list).
struct RpClosureVertex {
    position: vec3<f32>,
    object: u32,
    normal: vec3<f32>,
    // 1: drawn behind every reflector surface (a cap on the mirror's side).
    behind: u32,
}

// One per scene vertex.
struct RpVertex {
    // The virtual vertex (meaningful when `status` is RP_FOUND or RP_HIDDEN).
    position: vec3<f32>,
    status: u32,
    // The reflection point's texel.
    texel: vec2<i32>,
    // Steps of the forward search, and of the inverse search (0 when not run).
    iterations: u32,
    inverse_iterations: u32,
    // The reflected path's length |O - R| + |R - V|: the virtual vertex's distance for the
    // depth test (see reflection_point_raster.wgsl).
    path: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// `cpu::reflection_point::Status`.
const RP_REFLECTOR: u32 = 0u;
const RP_FOUND: u32 = 1u;
const RP_HIDDEN: u32 = 2u;
const RP_CAP: u32 = 3u;
const RP_NO_REFLECTOR: u32 = 4u;

// Score of a texel off the reflector (below any dot product of unit vectors).
const RP_OFF: f32 = -4.0;

@group(1) @binding(0) var<uniform> rp: RpParams;
@group(1) @binding(1) var reflector_position: texture_2d<f32>;
@group(1) @binding(2) var reflector_normal: texture_2d<f32>;
@group(1) @binding(3) var<storage, read_write> rp_vertices: array<RpVertex>;
// At least one element; only the first (reflector draw count - index_count) are read.
@group(1) @binding(4) var<storage, read> rp_closure: array<RpClosureVertex>;

// A closing triangle drawn behind has its reversed depth times this: behind every reflector
// surface (whose depth `near / distance` it could only exceed at 2^40 times the distance), in
// front of the clear value 0, and in its own order among closing triangles.
const RP_CLOSURE_BEHIND_SCALE: f32 = 9.094947e-13; // 2^-40

struct ReflectorVarying {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

@vertex
fn vs_reflector(@builtin(vertex_index) vertex: u32) -> ReflectorVarying {
    var out: ReflectorVarying;
    if vertex >= rp.index_count {
        let c = rp_closure[vertex - rp.index_count];
        var clip = rp.view_proj * vec4<f32>(c.position, 1.0);
        if c.behind != 0u {
            clip.z = clip.z * RP_CLOSURE_BEHIND_SCALE;
        }
        out.clip = clip;
        out.world = c.position;
        out.normal = c.normal;
        return out;
    }
    let v = scene_vertices[scene_indices[vertex]];
    // Other objects' triangles go outside the clip volume (x > w): no fragment.
    out.clip = select(vec4<f32>(2.0, 2.0, 0.5, 1.0), rp.view_proj * vec4<f32>(v.position, 1.0),
        scene_is_reflector(v.object));
    out.world = v.position;
    // T_N on the mirror's side: turned round where the normals point into a closed mesh.
    out.normal = scene_front_normal(v.object, v.normal);
    return out;
}

struct ReflectorOut {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
}

@fragment
fn fs_reflector(in: ReflectorVarying) -> ReflectorOut {
    return ReflectorOut(vec4<f32>(in.world, 1.0), vec4<f32>(in.normal, 1.0));
}

fn rp_dot(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn rp_on_reflector(t: vec2<i32>) -> bool {
    if t.x < 0 || t.y < 0 || t.x >= i32(rp.width) || t.y >= i32(rp.height) {
        return false;
    }
    return textureLoad(reflector_position, t, 0).w == 1.0;
}

// `v` mirrored in the plane through `r` with unit normal `n`.
fn rp_mirror(v: vec3<f32>, r: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return v - n * (2.0 * rp_dot(v - r, n));
}

// dot(N, B) at texel `t` for vertex `v` (`inverse`: `v` is the virtual vertex).
fn rp_score(t: vec2<i32>, v: vec3<f32>, inverse: bool) -> f32 {
    if !rp_on_reflector(t) {
        return RP_OFF;
    }
    let p = textureLoad(reflector_position, t, 0).xyz;
    let n = scene_normalize(textureLoad(reflector_normal, t, 0).xyz);
    var q = v;
    if inverse {
        q = rp_mirror(v, p, n);
    }
    let b = scene_normalize(scene_normalize(rp.eye - p) + scene_normalize(q - p));
    return rp_dot(n, b);
}

struct RpWalk {
    texel: vec2<i32>,
    iterations: u32,
    capped: bool,
}

// The local search from `start`: returns the texel where the centre won.
fn rp_walk(start: vec2<i32>, v: vec3<f32>, inverse: bool, first_crosshair: bool) -> RpWalk {
    var c = start;
    var it = 0u;
    loop {
        if it >= rp.max_iterations {
            return RpWalk(c, it, true);
        }
        it += 1u;
        var best = c;
        var best_score = rp_score(c, v, inverse);
        for (var dy = -1; dy <= 1; dy += 1) {
            for (var dx = -1; dx <= 1; dx += 1) {
                let cross = dx == 0 || dy == 0;
                if (dx == 0 && dy == 0) || (first_crosshair && it == 1u && !cross) {
                    continue;
                }
                let t = c + vec2<i32>(dx, dy);
                let s = rp_score(t, v, inverse);
                if s > best_score {
                    best = t;
                    best_score = s;
                }
            }
        }
        if best.x == c.x && best.y == c.y {
            return RpWalk(c, it, false);
        }
        c = best;
    }
    return RpWalk(c, it, true);
}

// The start texel: `rp.start` if it is on the reflector, else the nearest reflector texel
// along the crosshair's four arms (right, left, down, up at each distance); (-1, -1) when the
// arms meet none.
fn rp_start() -> vec2<i32> {
    let s = rp.start;
    if rp_on_reflector(s) {
        return s;
    }
    let reach = i32(max(rp.width, rp.height));
    for (var d = 1; d <= reach; d += 1) {
        let t = rp_start_arms(s, d);
        if t.x >= 0 {
            return t;
        }
    }
    return vec2<i32>(-1, -1);
}

// The crosshair's four arm texels at distance `d` from `s`: the first on the reflector, else
// (-1, -1). Its own function so that the cost model counts its turns (`model::work`'s
// `start_arms` block).
fn rp_start_arms(s: vec2<i32>, d: i32) -> vec2<i32> {
    let arms = array<vec2<i32>, 4>(
        vec2<i32>(d, 0), vec2<i32>(-d, 0), vec2<i32>(0, d), vec2<i32>(0, -d));
    for (var a = 0; a < 4; a += 1) {
        let t = s + arms[a];
        if rp_on_reflector(t) {
            return t;
        }
    }
    return vec2<i32>(-1, -1);
}

// The unit normal at the texel a walk ended on (`search`'s finish; the same operations as
// `rp_score`'s). A function of its own so that the cost model's `finish` block names it, not
// `scene_normalize`, which `rp_score` calls too (a function a block names is counted in that
// block only).
fn rp_found_normal(t: vec2<i32>) -> vec3<f32> {
    return scene_normalize(textureLoad(reflector_normal, t, 0).xyz);
}

// `v` mirrored in the found texel's plane (`rp_mirror`), for the cost model's `finish` block as
// `rp_found_normal` is.
fn rp_virtual_vertex(v: vec3<f32>, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return rp_mirror(v, p, n);
}

@compute @workgroup_size(64)
fn search(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.y * 65535u * 64u + gid.x;
    if i >= rp.vertex_count {
        return;
    }
    let vert = scene_vertices[i];
    var out = RpVertex(vec3<f32>(0.0), RP_REFLECTOR, vec2<i32>(-1, -1), 0u, 0u, 0.0, 0u, 0u, 0u);
    if scene_is_reflector(vert.object) {
        rp_vertices[i] = out;
        return;
    }
    let start = rp_start();
    if start.x < 0 {
        out.status = RP_NO_REFLECTOR;
        rp_vertices[i] = out;
        return;
    }
    let v = vert.position;
    let fwd = rp_walk(start, v, false, true);
    out.iterations = fwd.iterations;
    var t = fwd.texel;
    var capped = fwd.capped;
    out.status = RP_FOUND;
    var p = textureLoad(reflector_position, t, 0).xyz;
    var n = rp_found_normal(t);
    if !capped && rp_dot(v - p, n) < 0.0 {
        let inv = rp_walk(t, v, true, false);
        out.inverse_iterations = inv.iterations;
        t = inv.texel;
        capped = inv.capped;
        out.status = RP_HIDDEN;
        p = textureLoad(reflector_position, t, 0).xyz;
        n = rp_found_normal(t);
    }
    if capped {
        out.status = RP_CAP;
    }
    out.texel = t;
    out.position = rp_virtual_vertex(v, p, n);
    out.path = length(rp.eye - p) + length(v - p);
    rp_vertices[i] = out;
}
