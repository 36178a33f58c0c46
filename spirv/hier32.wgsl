// The `hier32` pass: one level of the alternating 4x8 / 8x4 [min, max] distance hierarchy of the
// compute path (thesis alg. 3) per dispatch.
//
// CPU twin: `cubetrace::cubemap::pyramid::Hier32::build` (+ `flatten`). Each invocation writes one
// destination cell: the min and max over the (up to) gx x gy source cells below it. A source
// child outside the source level is skipped, which is what the CPU does by padding with empty
// cells `[+inf, -inf]`, so N that is not a power of two (or not a multiple of the blocks) is
// handled exactly as on the CPU. The fold starts from child (0, 0), which always exists
// (dst x < ceil(w / gx) implies gx x < w), and visits the children in the CPU's row-major order,
// so the result is bit-identical to the CPU's for every non-NaN input, +inf texels included.
//
// Layouts (COMMON.md): `cmo_distance` holds K blocks of 6*N*N texels; `cmo_hier` holds K blocks
// of `hier32_len(N)` cells, each the `hier32_flat_layout(N)` levels concatenated, face-major,
// row-major. Level 1 reads the texels (a texel d is the cell [d, d]); level l > 1 reads level
// l - 1 of the same block. No barrier in this shader.

// Shared with Rust as `vk::passes::hier32::Hier32Params`; layout checked by tests/compute.rs.
struct Hier32Params {
    // Number of CMOs K.
    cmo_count: u32,
    // Cells per row / column of the source level (N, N for level 1).
    src_width: u32,
    src_height: u32,
    // First cell of the source level within a CMO's block (unused when from_texels != 0).
    src_offset: u32,
    // Cells per row / column of the destination level.
    dst_width: u32,
    dst_height: u32,
    // First cell of the destination level within a CMO's block.
    dst_offset: u32,
    // Cells per CMO in `cmo_hier`: hier32_len(N).
    hier_len: u32,
    // Block of source cells per destination cell (4 x 8 or 8 x 4).
    gx: u32,
    gy: u32,
    // 1 when the source is the texel level (`cmo_distance`), else 0.
    from_texels: u32,
    // Texels per CMO in `cmo_distance`: 6 * N * N.
    texels_per_cmo: u32,
}

@group(0) @binding(0) var<storage, read> params: Hier32Params;
@group(0) @binding(1) var<storage, read> cmo_distance: array<f32>;
@group(0) @binding(2) var<storage, read_write> cmo_hier: array<vec2<f32>>;
// The `gaps` entry point's: the `bounded` criterion's packed gaps (`[g1, g0]` in bfloat16
// halves, `cubemap::bounds::pack_gap`), laid out as `cmo_distance` and `cmo_hier`.
@group(0) @binding(3) var<storage, read> gap_texels: array<u32>;
@group(0) @binding(4) var<storage, read_write> gap_hier: array<u32>;

// Workgroup size; the dispatch is 2-D only to stay under maxComputeWorkGroupCount[0].
const WG: u32 = 64u;

fn source_cell(k: u32, face: u32, x: u32, y: u32) -> vec2<f32> {
    let local = (face * params.src_height + y) * params.src_width + x;
    if params.from_texels != 0u {
        let d = cmo_distance[k * params.texels_per_cmo + local];
        return vec2<f32>(d, d);
    }
    return cmo_hier[k * params.hier_len + params.src_offset + local];
}

// The destination cell of invocation `gid` (`ok` false past the last cell).
struct Dest {
    ok: bool,
    k: u32,
    face: u32,
    sx: u32,
    sy: u32,
    in_cmo: u32,
}

fn dest(gid: vec3<u32>, groups: vec3<u32>) -> Dest {
    let index = gid.y * (groups.x * WG) + gid.x;
    let w = params.dst_width;
    let per_face = w * params.dst_height;
    let per_cmo = 6u * per_face;
    let in_cmo = index % per_cmo;
    let x = in_cmo % w;
    let y = (in_cmo % per_face) / w;
    return Dest(index < params.cmo_count * per_cmo, index / per_cmo, in_cmo / per_face, params.gx * x, params.gy * y, in_cmo);
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
    var mm = source_cell(d.k, d.face, d.sx, d.sy);
    for (var cy = d.sy; cy < d.sy + params.gy && cy < params.src_height; cy++) {
        for (var cx = d.sx; cx < d.sx + params.gx && cx < params.src_width; cx++) {
            if cx == d.sx && cy == d.sy {
                continue;
            }
            let c = source_cell(d.k, d.face, cx, cy);
            mm = vec2<f32>(min(mm.x, c.x), max(mm.y, c.y));
        }
    }
    cmo_hier[d.k * params.hier_len + params.dst_offset + d.in_cmo] = mm;
}

// Source gap cell `(x, y)` of `face` in CMO `k`, unpacked (`[g1, g0]`).
fn gap_source(k: u32, face: u32, x: u32, y: u32) -> vec2<f32> {
    let local = (face * params.src_height + y) * params.src_width + x;
    var w: u32;
    if params.from_texels != 0u {
        w = gap_texels[k * params.texels_per_cmo + local];
    } else {
        w = gap_hier[k * params.hier_len + params.src_offset + local];
    }
    return vec2<f32>(bitcast<f32>(w & 0xffff0000u), bitcast<f32>(w << 16u));
}

// The gaps' hierarchy (`cpu::bounded::Bounded::gap_hier`, `Hier32::over_cells`): as `main`, the
// min of `g1` (x) and the max of `g0` (y) over the block in the same order; the unpacked halves
// are bfloat16 values, so packing the result again is exact.
@compute @workgroup_size(64)
fn gaps(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let d = dest(gid, groups);
    if !d.ok {
        return;
    }
    var g = gap_source(d.k, d.face, d.sx, d.sy);
    for (var cy = d.sy; cy < d.sy + params.gy && cy < params.src_height; cy++) {
        for (var cx = d.sx; cx < d.sx + params.gx && cx < params.src_width; cx++) {
            if cx == d.sx && cy == d.sy {
                continue;
            }
            let c = gap_source(d.k, d.face, cx, cy);
            g = vec2<f32>(min(g.x, c.x), max(g.y, c.y));
        }
    }
    gap_hier[d.k * params.hier_len + params.dst_offset + d.in_cmo] = (bitcast<u32>(g.x) & 0xffff0000u) | (bitcast<u32>(g.y) >> 16u);
}
