// ssr_hiz: the min Hi-Z pyramid of the G-buffer's depth (Uludag 2014, section 4.4.1 and Listing 4.3),
// one dispatch per level. Level 0 converts the G-buffer's world positions to the depth key of
// shared/ssr.wgsl; level l > 0 takes the min over the (up to) 2 x 2 cells of level l - 1 below
// each cell, children outside the finer level skipped, visited row-major from child (0, 0)
// (which always exists). CPU twin: `cubetrace::cpu::ssr::build_hiz`.
//! import shared/ssr.wgsl

struct HizLevel {
    level: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var gbuffer_position: texture_2d<f32>;
@group(0) @binding(1) var<storage, read> ssr: SsrParams;
@group(0) @binding(2) var<storage, read_write> hiz: array<f32>;
@group(0) @binding(3) var<storage, read> hiz_level: HizLevel;

const WG: u32 = 64u;

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let index = gid.y * (groups.x * WG) + gid.x;
    let l = hiz_level.level;
    let dst = ssr.levels[l];
    // No barrier in this shader: an early return is uniform-safe.
    if index >= dst.y * dst.z {
        return;
    }
    let x = index % dst.y;
    let y = index / dst.y;
    if l == 0u {
        let p = textureLoad(gbuffer_position, vec2<i32>(vec2<u32>(x, y)), 0);
        hiz[dst.x + index] = ssr_depth_key(ssr.view_proj, p);
        return;
    }
    let src = ssr.levels[l - 1u];
    let sx = 2u * x;
    let sy = 2u * y;
    var m = hiz[src.x + sy * src.y + sx];
    if sx + 1u < src.y {
        m = min(m, hiz[src.x + sy * src.y + sx + 1u]);
    }
    if sy + 1u < src.z {
        m = min(m, hiz[src.x + (sy + 1u) * src.y + sx]);
        if sx + 1u < src.y {
            m = min(m, hiz[src.x + (sy + 1u) * src.y + sx + 1u]);
        }
    }
    hiz[dst.x + index] = m;
}
