// hit_probe: runs the verified-hit building blocks on given inputs, for the tests against their
// CPU twins (`tests/common/hit_probe.rs`). `watertight_main`: one watertight ray-triangle test per
// query (shared/watertight.wgsl). `shade_main`: shading at (triangle, barycentrics) per query
// (shared/hit.wgsl). `verify_main`: the verified-hit rule per query (shared/verify.wgsl), with
// the neighbourhood's IDs read from one CMO's ID cube.

// The scene's bind group (shared/scene.wgsl).
const SCENE_GROUP: u32 = 0u;
//! import shared/hit.wgsl
//! import shared/watertight.wgsl
//! import shared/verify.wgsl

// Shared with Rust as `tests/common/hit_probe.rs`'s `WatertightQuery`.
struct WatertightQuery {
    org: vec3<f32>,
    _pad0: u32,
    dir: vec3<f32>,
    _pad1: u32,
    p0: vec3<f32>,
    _pad2: u32,
    p1: vec3<f32>,
    _pad3: u32,
    p2: vec3<f32>,
    _pad4: u32,
}

// Shared with Rust as `tests/common/hit_probe.rs`'s `WatertightResult`.
struct WatertightResult {
    bary: vec3<f32>,
    t: f32,
    hit: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Shared with Rust as `tests/common/hit_probe.rs`'s `ShadeQuery`.
struct ShadeQuery {
    bary: vec2<f32>,
    triangle: u32,
    _pad: u32,
}

// Shared with Rust as `tests/common/hit_probe.rs`'s `VerifyQuery`: the ray, its prefix and end, the CMO centre
// and face size, and the deciding texel.
struct VerifyQuery {
    a: vec3<f32>,
    t_done: f32,
    d: vec3<f32>,
    t_hi: f32,
    centre: vec3<f32>,
    size: u32,
    face: u32,
    x: u32,
    y: u32,
    _pad: u32,
}

// Shared with Rust as `tests/common/hit_probe.rs`'s `VerifyResult`.
struct VerifyResult {
    bary: vec3<f32>,
    t: f32,
    position: vec3<f32>,
    triangle: u32,
    hit: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(1) @binding(0) var<storage, read> wt_queries: array<WatertightQuery>;
@group(1) @binding(1) var<storage, read_write> wt_results: array<WatertightResult>;
@group(1) @binding(2) var<storage, read> shade_queries: array<ShadeQuery>;
@group(1) @binding(3) var<storage, read_write> shade_results: array<vec4<f32>>;
@group(1) @binding(4) var<storage, read> verify_queries: array<VerifyQuery>;
// One CMO's triangle IDs, `CubeMap::triangle`'s layout.
@group(1) @binding(5) var<storage, read> verify_ids: array<u32>;
@group(1) @binding(6) var<storage, read_write> verify_results: array<VerifyResult>;

@compute @workgroup_size(64)
fn watertight_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&wt_queries) {
        return;
    }
    let q = wt_queries[i];
    let h = wt_intersect(q.org, q.dir, q.p0, q.p1, q.p2);
    wt_results[i] = WatertightResult(h.bary, h.t, select(0u, 1u, h.hit), 0u, 0u, 0u);
}

@compute @workgroup_size(64)
fn shade_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&shade_queries) {
        return;
    }
    let q = shade_queries[i];
    shade_results[i] = vec4<f32>(hit_shade(q.triangle, q.bary), 1.0);
}

@compute @workgroup_size(64)
fn verify_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&verify_queries) {
        return;
    }
    let q = verify_queries[i];
    var h = verify_hood_texels(Texel(q.face, q.x, q.y), q.size);
    for (var k = 0u; k < 9u; k++) {
        h.ids[k] = verify_ids[texel_index(h.texels[k], q.size)];
    }
    let v = verify_hit(q.a, q.d, q.t_done, q.t_hi, q.centre, q.size, h);
    verify_results[i] = VerifyResult(v.bary, v.t, v.position, v.triangle, select(0u, 1u, v.hit), 0u, 0u, 0u);
}
