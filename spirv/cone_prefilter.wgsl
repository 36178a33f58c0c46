// The `cone_prefilter` pass: one level of the pre-filtered colour chain of K CMOs per dispatch
// (cone tracing on the cube maps; the lookups are spirv/shared/cone.wgsl).
//
// CPU twin: `cubetrace::cpu::cone::cone_prefilter`, bit for bit. Each invocation writes one cell
// of level l: the box average of the (up to) 2x2 cells of level l - 1 below it, summed in the
// CPU's order (row-major, the children that exist) and scaled by 1/count (1, 1/2 or 1/4: exact).
// Level 1 reads the captured colour (`cmo_colour`, layer 6 k + face), an empty texel (alpha 0)
// as (background, 0), a captured one as (rgb, 1): alpha is the coverage.
//
// Layouts: `cmo_cone` holds K blocks of `mip_len(N)` vec4 cells, each the `mip_flat_layout(N)`
// levels concatenated, face-major, row-major (the layout of `cmo_mip`, see spirv/pyramid.wgsl).

// Shared with Rust as `vk::passes::cone::ConePrefilterParams`; layout checked by
// tests/glossy/glossy_cone.rs.
struct ConePrefilterParams {
    // Number of CMOs K.
    cmo_count: u32,
    // Cells per side of the source level (N for level 1).
    src_width: u32,
    // First cell of the source level within a CMO's block (unused when from_texels != 0).
    src_offset: u32,
    // Cells per side of the destination level: ceil(src_width / 2).
    dst_width: u32,
    // First cell of the destination level within a CMO's block.
    dst_offset: u32,
    // Cells per CMO in `cmo_cone`: mip_len(N).
    cone_len: u32,
    // 1 when the source is the captured colour, else 0.
    from_texels: u32,
    pad0: u32,
    // What an empty texel stands for.
    background: vec3<f32>,
    pad1: u32,
}

@group(0) @binding(0) var<storage, read> params: ConePrefilterParams;
@group(0) @binding(1) var prefilter_colour: texture_2d_array<f32>;
@group(0) @binding(2) var<storage, read_write> prefilter_cone: array<vec4<f32>>;

const WG: u32 = 64u;

fn source_cell(k: u32, face: u32, x: u32, y: u32) -> vec4<f32> {
    if params.from_texels != 0u {
        let c = textureLoad(prefilter_colour, vec2<u32>(x, y), k * 6u + face, 0);
        if c.w > 0.0 {
            return vec4<f32>(c.xyz, 1.0);
        }
        return vec4<f32>(params.background, 0.0);
    }
    let w = params.src_width;
    return prefilter_cone[k * params.cone_len + params.src_offset + (face * w + y) * w + x];
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let index = gid.y * (groups.x * WG) + gid.x;
    let w = params.dst_width;
    let per_face = w * w;
    let per_cmo = 6u * per_face;
    // No barrier in this shader, so an early return is uniform-safe.
    if index >= params.cmo_count * per_cmo {
        return;
    }
    let k = index / per_cmo;
    let in_cmo = index % per_cmo;
    let face = in_cmo / per_face;
    let x = in_cmo % w;
    let y = (in_cmo % per_face) / w;

    let sx = 2u * x;
    let sy = 2u * y;
    let sw = params.src_width;
    var sum = source_cell(k, face, sx, sy);
    var count = 1u;
    if sx + 1u < sw {
        sum += source_cell(k, face, sx + 1u, sy);
        count += 1u;
    }
    if sy + 1u < sw {
        sum += source_cell(k, face, sx, sy + 1u);
        count += 1u;
        if sx + 1u < sw {
            sum += source_cell(k, face, sx + 1u, sy + 1u);
            count += 1u;
        }
    }
    var weight = 1.0;
    if count == 4u {
        weight = 0.25;
    } else if count == 2u {
        weight = 0.5;
    }
    prefilter_cone[k * params.cone_len + params.dst_offset + in_cmo] = sum * weight;
}
