// hit_probe: runs the verified-hit building blocks on given inputs, for the tests against their
// CPU twins (`src/vk/hit_probe.rs`). `watertight_main`: one watertight ray-triangle test per
// query (shared/watertight.wgsl). `shade_main`: shading at (triangle, barycentrics) per query
// (shared/hit.wgsl).
//! import shared/hit.wgsl
//! import shared/watertight.wgsl

// Shared with Rust as `vk::hit_probe::WatertightQuery`.
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

// Shared with Rust as `vk::hit_probe::WatertightResult`.
struct WatertightResult {
    bary: vec3<f32>,
    t: f32,
    hit: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Shared with Rust as `vk::hit_probe::ShadeQuery`.
struct ShadeQuery {
    bary: vec2<f32>,
    triangle: u32,
    _pad: u32,
}

@group(1) @binding(0) var<storage, read> wt_queries: array<WatertightQuery>;
@group(1) @binding(1) var<storage, read_write> wt_results: array<WatertightResult>;
@group(1) @binding(2) var<storage, read> shade_queries: array<ShadeQuery>;
@group(1) @binding(3) var<storage, read_write> shade_results: array<vec4<f32>>;

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
