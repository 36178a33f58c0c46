// Cone tracing on the cube maps: the lookups into the pre-filtered colour chain, the WGSL twin
// of `cubetrace::cpu::cone` (src/cpu/cone.rs), operation for operation. Read its module docs for
// the chain (levels 1..=L in `mip_flat_layout(N)` order, box averages, empty texels as the
// background, alpha the coverage), the trilinear lookup (clamped at the face edges: no filtering
// across a seam), the footprint level and the direction-only lookup.
//
// Data (@group(1), besides shared/trace.wgsl's and shared/mirror.wgsl's `cmo_colour`): binding
// 14 `cmo_cone`, `mip_len(N)` vec4 cells per CMO (`CmoData::alloc_cone`, written by the
// `cone_prefilter` pass). The background an empty texel stands for is an argument, so that a
// pass can pass `frame.background` (or a test its own).
//! import shared/mirror.wgsl
//! import shared/lobe.wgsl

@group(1) @binding(14) var<storage, read> cmo_cone: array<vec4<f32>>;

// `cone_texel`: a captured colour as the chain sees it.
fn cone_texel(c: vec4<f32>, background: vec3<f32>) -> vec4<f32> {
    if c.w > 0.0 {
        return vec4<f32>(c.xyz, 1.0);
    }
    return vec4<f32>(background, 0.0);
}

// `cone_level_at`: (first cell, width) of level l >= 1 of the chain of face size `size`.
fn cone_level_at(size: u32, l: u32) -> vec2<u32> {
    var offset = 0u;
    var w = size;
    for (var i = 1u; i < l; i++) {
        w = (w + 1u) / 2u;
        offset += FACE_COUNT * w * w;
    }
    return vec2<u32>(offset, (w + 1u) / 2u);
}

// Cells per CMO of `cmo_cone`: `mip_len(N)`, the cells of every level.
fn cone_len(size: u32) -> u32 {
    return cone_level_at(size, cone_top(size) + 1u).x;
}

// Levels above the texels: `mip_flat_layout(N).len()`.
fn cone_top(size: u32) -> u32 {
    var w = size;
    var l = 0u;
    while w > 1u {
        w = (w + 1u) / 2u;
        l += 1u;
    }
    return l;
}

fn cone_cell(k: u32, l: u32, face: u32, x: u32, y: u32, background: vec3<f32>) -> vec4<f32> {
    let size = trace_config.size;
    if l == 0u {
        return cone_texel(textureLoad(cmo_colour, vec2<u32>(x, y), k * 6u + face, 0), background);
    }
    let at = cone_level_at(size, l);
    let w = at.y;
    return cmo_cone[k * cone_len(size) + at.x + (face * w + y) * w + x];
}

// `cone_axis`: (lower cell, upper cell, weight of the upper) as bits; see the CPU twin.
struct ConeAxis {
    x0: u32,
    x1: u32,
    f: f32,
}

fn cone_axis(s: f32, scale: f32, w: u32) -> ConeAxis {
    let last = f32(w - 1u);
    var p = prod(s, scale) - 0.5;
    if p < 0.0 {
        p = 0.0;
    } else if p > last {
        p = last;
    }
    let f = floor(p);
    let x0 = u32(f);
    return ConeAxis(x0, min(x0 + 1u, w - 1u), p - f);
}

// `a + (b - a) f`, the product rounded on its own (see `prod` in shared/frustum.wgsl).
fn cone_lerp(a: vec4<f32>, b: vec4<f32>, f: f32) -> vec4<f32> {
    return a + (b - a) * f;
}

fn cone_level_colour(k: u32, l: u32, face: u32, s: f32, t: f32, background: vec3<f32>) -> vec4<f32> {
    let size = trace_config.size;
    var w = size;
    if l != 0u {
        w = cone_level_at(size, l).y;
    }
    let scale = f32(size) / f32(1u << l);
    let ax = cone_axis(s, scale, w);
    let ay = cone_axis(t, scale, w);
    let top = cone_lerp(
        cone_cell(k, l, face, ax.x0, ay.x0, background),
        cone_cell(k, l, face, ax.x1, ay.x0, background),
        ax.f,
    );
    let bottom = cone_lerp(
        cone_cell(k, l, face, ax.x0, ay.x1, background),
        cone_cell(k, l, face, ax.x1, ay.x1, background),
        ax.f,
    );
    return cone_lerp(top, bottom, ay.f);
}

// `cone_cube_colour4`: trilinear colour and coverage of CMO k along `dir` at level `level`.
fn cone_cube_colour4(k: u32, dir: vec3<f32>, level: f32, background: vec3<f32>) -> vec4<f32> {
    // `dir_to_face_st`, as `dir_to_texel` (shared/cube.wgsl) computes it.
    let face = select_face(dir);
    let lf = to_face_local(face, dir);
    var s = 0.5;
    var t = 0.5;
    if lf.z > 0.0 {
        s = clamp_rust(0.5 * (lf.x / lf.z + 1.0), 0.0, 1.0);
        t = clamp_rust(0.5 * (lf.y / lf.z + 1.0), 0.0, 1.0);
    }
    let top = cone_top(trace_config.size);
    var lv = 0.0;
    if level > 0.0 {
        lv = level;
    }
    let f0 = floor(lv);
    if f0 >= f32(top) {
        return cone_level_colour(k, top, face, s, t, background);
    }
    let l0 = u32(f0);
    let fl = lv - f0;
    let a = cone_level_colour(k, l0, face, s, t, background);
    if fl > 0.0 {
        let b = cone_level_colour(k, l0 + 1u, face, s, t, background);
        return cone_lerp(a, b, fl);
    }
    return a;
}

// `cone_cube_colour`: the colour of `cone_cube_colour4`.
fn cone_cube_colour(k: u32, dir: vec3<f32>, level: f32, background: vec3<f32>) -> vec3<f32> {
    return cone_cube_colour4(k, dir, level, background).xyz;
}

// `cone_footprint_level`: the level whose cell width matches a cone of half-angle
// atan(tan_half) around `dir` seen from the CMO centre.
fn cone_footprint_level(size: u32, dir: vec3<f32>, tan_half: f32) -> f32 {
    let l = to_face_local(select_face(dir), dir);
    let r2 = (prod(l.x, l.x) + prod(l.y, l.y) + prod(l.z, l.z)) / (l.z * l.z);
    return log2(tan_half * f32(size)) + prod(0.75, log2(r2));
}

// `cone_envmap_colour`: the direction-only lookup of the lobe of power `power` around `dir`.
fn cone_envmap_colour(k: u32, dir: vec3<f32>, power: f32, background: vec3<f32>) -> vec3<f32> {
    let tan_half = tan(lobe_cone_angle(power));
    let level = cone_footprint_level(trace_config.size, dir, tan_half);
    return cone_cube_colour(k, dir, level, background);
}
