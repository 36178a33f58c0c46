// Cone probe pass: evaluates the cone lookups of spirv/shared/cone.wgsl for a list of queries,
// one result per query. It exists to compare them with their CPU twins (`cubetrace::cpu::cone`,
// tests/glossy/glossy_cone.rs); the cone pass and ssr call the same functions.
// Group 0 (bindings 8 to 10, clear of shared/mirror.wgsl's 0 to 3): the queries and results;
// group 1: the CMO data (`CmoData`, with `cmo_cone`).
//! import shared/cone.wgsl

// One query (Rust: `vk::passes::cone::ConeQuery`).
struct ConeQuery {
    dir: vec3<f32>,
    // mode 0: the level; mode 1: the specular power; mode 2: tan of the half-angle.
    arg: f32,
    k: u32,
    // 0 `cone_cube_colour4`, 1 `cone_envmap_colour` (alpha 0), 2 `cone_footprint_level` (in x).
    mode: u32,
    pad0: u32,
    pad1: u32,
}

// Rust: `vk::passes::cone::ConeProbeParams`.
struct ConeProbeParams {
    count: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
    background: vec3<f32>,
    pad3: u32,
}

@group(0) @binding(8) var<storage, read> probe_params: ConeProbeParams;
@group(0) @binding(9) var<storage, read> probe_queries: array<ConeQuery>;
@group(0) @binding(10) var<storage, read_write> probe_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= probe_params.count {
        return;
    }
    let q = probe_queries[i];
    let bg = probe_params.background;
    var out = vec4<f32>(0.0);
    if q.mode == 0u {
        out = cone_cube_colour4(q.k, q.dir, q.arg, bg);
    } else if q.mode == 1u {
        out = vec4<f32>(cone_envmap_colour(q.k, q.dir, q.arg, bg), 0.0);
    } else {
        out = vec4<f32>(cone_footprint_level(trace_config.size, q.dir, q.arg), 0.0, 0.0, 0.0);
    }
    probe_out[i] = out;
}
