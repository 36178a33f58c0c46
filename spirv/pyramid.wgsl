// The `pyramid` pass: one level of the 2x2 [min, max] distance pyramid per dispatch (`main`),
// or of the `bounded` criterion's gaps (`gaps`, at the end).
//
// CPU twin: `cubetrace::cubemap::pyramid::MipPyramid::build` (+ `flatten`). Each invocation
// writes one destination cell: the min and max over the (up to) 2x2 source cells below it. A
// source child outside the source level is replaced by its neighbour inside (`children`), whose
// value min and max already hold; the CPU pads with empty cells `[+inf, -inf]` instead
// (min(+inf, x) = x and max(-inf, x) = x for every non-NaN x). Child (0, 0) always exists
// (dst x < ceil(w / 2) implies 2x < w), and min and max are exact, so the result is
// bit-identical to the CPU's for every non-NaN input, +inf texels and whole +inf faces
// included, without an inf literal.
// (Distances are >= 0 by definition; should +0.0 and -0.0 meet in one cell, which of the two is
// the min is left to the implementation, on the CPU as here.)
//
// Layouts (COMMON.md): `cmo_distance` holds K blocks of 6*N*N texels; `cmo_mip` holds K blocks
// of `mip_len(N)` cells, each the `mip_flat_layout(N)` levels concatenated, face-major,
// row-major. Level 1 reads the texels (a texel d is the cell [d, d]); level l > 1 reads level
// l - 1 of the same block. Levels are square (ceil(N / 2^l) on both sides).

// Shared with Rust as `vk::passes::pyramid::PyramidParams`; layout checked by tests/capture/gpu_pyramid.rs.
struct PyramidParams {
    // Number of CMOs K.
    cmo_count: u32,
    // Cells per side of the source level (N for level 1).
    src_width: u32,
    // First cell of the source level within a CMO's mip block (unused when from_texels != 0).
    src_offset: u32,
    // Cells per side of the destination level: ceil(src_width / 2).
    dst_width: u32,
    // First cell of the destination level within a CMO's mip block.
    dst_offset: u32,
    // Cells per CMO in `cmo_mip`: mip_len(N).
    mip_len: u32,
    // 1 when the source is the texel level (`cmo_distance`), else 0.
    from_texels: u32,
    // Texels per CMO in `cmo_distance`: 6 * N * N.
    texels_per_cmo: u32,
}

@group(0) @binding(0) var<storage, read> params: PyramidParams;
@group(0) @binding(1) var<storage, read> cmo_distance: array<f32>;
@group(0) @binding(2) var<storage, read_write> cmo_mip: array<vec2<f32>>;
// The `gaps` entry point's: the `bounded` criterion's packed gaps (`[g1, g0]` in bfloat16
// halves, `cubemap::bounds::pack_gap`), laid out as `cmo_distance` and `cmo_mip`.
@group(0) @binding(3) var<storage, read> gap_texels: array<u32>;
@group(0) @binding(4) var<storage, read_write> gap_mip: array<u32>;

// Workgroup size; the dispatch is 2-D only to stay under maxComputeWorkGroupCount[0].
const WG: u32 = 64u;

// Source cell `(x, y)` of `face` in CMO `k` as [min, max].
fn source_cell(k: u32, face: u32, x: u32, y: u32) -> vec2<f32> {
    let local = (face * params.src_width + y) * params.src_width + x;
    if params.from_texels != 0u {
        let d = cmo_distance[k * params.texels_per_cmo + local];
        return vec2<f32>(d, d);
    }
    return cmo_mip[k * params.mip_len + params.src_offset + local];
}

// The destination cell of invocation `gid`: CMO, face, x, y and its index within the CMO's
// level (`ok` false past the last cell).
struct Dest {
    ok: bool,
    k: u32,
    face: u32,
    x: u32,
    y: u32,
    in_cmo: u32,
}

fn dest(gid: vec3<u32>, groups: vec3<u32>) -> Dest {
    let index = gid.y * (groups.x * WG) + gid.x;
    let w = params.dst_width;
    let per_face = w * w;
    let per_cmo = 6u * per_face;
    let in_cmo = index % per_cmo;
    let face = in_cmo / per_face;
    return Dest(index < params.cmo_count * per_cmo, index / per_cmo, face, in_cmo % w, (in_cmo % per_face) / w, in_cmo);
}

// The 2x2 children of `d`'s cell as (x0, y0, x1, y1), clamped to the source level: a child
// past the level's edge repeats its neighbour, which min and max leave unchanged (as the CPU's
// empty padding cells do).
fn children(d: Dest) -> vec4<u32> {
    let sx = 2u * d.x;
    let sy = 2u * d.y;
    let last = params.src_width - 1u;
    return vec4<u32>(sx, sy, min(sx + 1u, last), min(sy + 1u, last));
}

// [min, max] of two cells.
fn fold(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(min(a.x, b.x), max(a.y, b.y));
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let d = dest(gid, groups);
    // No barrier in this shader, so an early return is uniform-safe.
    if !d.ok {
        return;
    }
    let c = children(d);
    let top = fold(source_cell(d.k, d.face, c.x, c.y), source_cell(d.k, d.face, c.z, c.y));
    let bottom = fold(source_cell(d.k, d.face, c.x, c.w), source_cell(d.k, d.face, c.z, c.w));
    cmo_mip[d.k * params.mip_len + params.dst_offset + d.in_cmo] = fold(top, bottom);
}

// `[g1, g0]` of a packed gap word (shared/trace.wgsl's `unpack_gap`).
fn gap_unpack(w: u32) -> vec2<f32> {
    return vec2<f32>(bitcast<f32>(w & 0xffff0000u), bitcast<f32>(w << 16u));
}

// Source gap cell `(x, y)` of `face` in CMO `k`, unpacked.
fn gap_source(k: u32, face: u32, x: u32, y: u32) -> vec2<f32> {
    let local = (face * params.src_width + y) * params.src_width + x;
    if params.from_texels != 0u {
        return gap_unpack(gap_texels[k * params.texels_per_cmo + local]);
    }
    return gap_unpack(gap_mip[k * params.mip_len + params.src_offset + local]);
}

// The gaps' pyramid (`cpu::bounded::Bounded::gaps`, `MipPyramid::over_cells`): as `main`, the
// min of `g1` (x) and the max of `g0` (y) over the 2x2 children in the same order. The unpacked
// halves are bfloat16 values, so packing the result again is exact.
@compute @workgroup_size(64)
fn gaps(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let d = dest(gid, groups);
    if !d.ok {
        return;
    }
    let c = children(d);
    let top = fold(gap_source(d.k, d.face, c.x, c.y), gap_source(d.k, d.face, c.z, c.y));
    let bottom = fold(gap_source(d.k, d.face, c.x, c.w), gap_source(d.k, d.face, c.z, c.w));
    let g = fold(top, bottom);
    gap_mip[d.k * params.mip_len + params.dst_offset + d.in_cmo] = (bitcast<u32>(g.x) & 0xffff0000u) | (bitcast<u32>(g.y) >> 16u);
}
