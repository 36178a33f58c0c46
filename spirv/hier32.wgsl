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

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let index = gid.y * (groups.x * WG) + gid.x;
    let w = params.dst_width;
    let per_face = w * params.dst_height;
    let per_cmo = 6u * per_face;
    if index >= params.cmo_count * per_cmo {
        return;
    }
    let k = index / per_cmo;
    let in_cmo = index % per_cmo;
    let face = in_cmo / per_face;
    let x = in_cmo % w;
    let y = (in_cmo % per_face) / w;
    let sx = params.gx * x;
    let sy = params.gy * y;
    var mm = source_cell(k, face, sx, sy);
    for (var cy = sy; cy < sy + params.gy && cy < params.src_height; cy++) {
        for (var cx = sx; cx < sx + params.gx && cx < params.src_width; cx++) {
            if cx == sx && cy == sy {
                continue;
            }
            let c = source_cell(k, face, cx, cy);
            mm = vec2<f32>(min(mm.x, c.x), max(mm.y, c.y));
        }
    }
    cmo_hier[k * params.hier_len + params.dst_offset + in_cmo] = mm;
}
