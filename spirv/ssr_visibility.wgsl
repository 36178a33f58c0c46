// ssr_visibility: the max Hi-Z pyramid beside `ssr_hiz`'s min one (section 4.4.1) and the
// pre-integrated visibility pyramid (section 4.4.2, Listing 4.4), one dispatch per level l >= 1
// after `ssr_hiz` (level 0: max = the depth keys, visibility 1). CPU twin:
// `cubetrace::cpu::ssr_cone::build_visibility`.
//
// Per cell of level l: `max` over the (up to) 2 x 2 cells below, children visited row-major from
// (0, 0) as `ssr_hiz`. Visibility: with [w_min, w_max] the view depths of the cell's min and max
// keys, each child c contributes (w_c - w_min) / (w_max - w_min) * visibility_c, w_c the view
// depth of the child's min key: the fraction of the cell's depth slab that lies empty in front of
// the child (Figure 4.8). Listing 4.4 prints `fineZ * coarseVolume`; the fraction of empty volume
// its text describes is `(fineZ - minZ) * coarseVolume`. A flat cell (w_max <= w_min) passes its
// children's visibility on (fraction 1). Children are averaged (the listing's weight 0.25; over
// the existing children where a level has an odd size), so a cell's visibility is at most the
// mean of its children's. f32, not the chapter's 8 bits, so that the
// twin can compare bits.
//! import shared/ssr.wgsl
//! import shared/ssr_cone.wgsl

@group(0) @binding(0) var<storage, read> ssr: SsrParams;
@group(0) @binding(1) var<storage, read> hiz: array<f32>;
@group(0) @binding(2) var<storage, read_write> hiz_max: array<f32>;
@group(0) @binding(3) var<storage, read_write> visibility: array<f32>;
@group(0) @binding(4) var<storage, read> cone_level: ConeLevel;

const WG: u32 = 64u;

// The fraction of child `c`'s share of the cell that is visible.
fn child_fraction(child_min: f32, w_min: f32, w_max: f32) -> f32 {
    if !(w_max > w_min) {
        return 1.0;
    }
    return (ssr_cone_depth(child_min) - w_min) / (w_max - w_min);
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let index = gid.y * (groups.x * WG) + gid.x;
    let l = cone_level.level;
    let dst = ssr.levels[l];
    // No barrier in this shader: an early return is uniform-safe.
    if index >= dst.y * dst.z {
        return;
    }
    if l == 0u {
        hiz_max[index] = hiz[index];
        visibility[index] = 1.0;
        return;
    }
    let x = index % dst.y;
    let y = index / dst.y;
    let src = ssr.levels[l - 1u];
    let sx = 2u * x;
    let sy = 2u * y;
    var m = hiz_max[src.x + sy * src.y + sx];
    if sx + 1u < src.y {
        m = max(m, hiz_max[src.x + sy * src.y + sx + 1u]);
    }
    if sy + 1u < src.z {
        m = max(m, hiz_max[src.x + (sy + 1u) * src.y + sx]);
        if sx + 1u < src.y {
            m = max(m, hiz_max[src.x + (sy + 1u) * src.y + sx + 1u]);
        }
    }
    hiz_max[dst.x + index] = m;
    let w_min = ssr_cone_depth(hiz[dst.x + index]);
    let w_max = ssr_cone_depth(m);
    let c00 = src.x + sy * src.y + sx;
    var sum = child_fraction(hiz[c00], w_min, w_max) * visibility[c00];
    var n = 1.0;
    if sx + 1u < src.y {
        sum = sum + child_fraction(hiz[c00 + 1u], w_min, w_max) * visibility[c00 + 1u];
        n = n + 1.0;
    }
    if sy + 1u < src.z {
        let c01 = c00 + src.y;
        sum = sum + child_fraction(hiz[c01], w_min, w_max) * visibility[c01];
        n = n + 1.0;
        if sx + 1u < src.y {
            sum = sum + child_fraction(hiz[c01 + 1u], w_min, w_max) * visibility[c01 + 1u];
            n = n + 1.0;
        }
    }
    visibility[dst.x + index] = sum / n;
}
