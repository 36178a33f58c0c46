// What the two passes of the screen-space method share (`ssr_hiz` builds the pyramid, `ssr`
// traverses it); the CPU twin is `src/cpu/ssr.rs`.
//
// Depth: the pyramid stores `q = -1 / w` per pixel, `w` the clip-space w of the G-buffer's world
// position (the distance along the view axis). `q` is an affine function of the post-projective
// depth `z / w`, so it interpolates linearly in screen space as the chapter requires, and its
// order is the depth buffer's (nearer = smaller); unlike the depth buffer's `z / w` (`near / w`
// with the reversed infinite projection, crowded towards 0 far away) it does not depend on the
// near plane. The parameters are a read-only storage buffer, not a uniform: lavapipe re-JITs a
// shader per bind when it branches on uniform values (spirv/README.md). Pixels where nothing was drawn hold 0
// (infinitely far). Levels: level 0 is the frame (W x H); level l has ceil(W / 2^l) x
// ceil(H / 2^l) cells, each the min over the (up to) 2 x 2 cells below it, down to 1 x 1; they
// are stored one after another, row-major (`levels[l]` = (offset, width, height, 0)).
//
// Products are written as plain `a * b`: lavapipe never fuses them (see `prod` in
// shared/frustum.wgsl), which keeps the CPU twin bit-identical.

// Shared with Rust as `vk::methods::ssr::SsrParams` (layout checked in tests/ssr.rs).
struct SsrParams {
    view_proj: mat4x4<f32>,
    levels: array<vec4<u32>, 16>,
    width: u32,
    height: u32,
    level_count: u32,
    // Loop iterations before a ray is given up (unresolved).
    max_iterations: u32,
    // Thickness test (when `thickness_on` != 0): a hit more than `thickness` world units (along
    // the view axis) behind the surface it lands on is unresolved.
    thickness: f32,
    thickness_on: u32,
    // Pixels the ray is pushed past a cell boundary, so that it lands in the next cell.
    cross_epsilon: f32,
    pad0: u32,
}

// `m * vec4(p, w)` with the products and sums in glam's order (column by column).
fn ssr_clip(m: mat4x4<f32>, p: vec3<f32>, w: f32) -> vec4<f32> {
    return ((m[0] * p.x + m[1] * p.y) + m[2] * p.z) + m[3] * w;
}

// The pyramid's depth key of a G-buffer position texel (`w` < 0: nothing drawn).
fn ssr_depth_key(m: mat4x4<f32>, position: vec4<f32>) -> f32 {
    if position.w < 0.0 {
        return 0.0;
    }
    let c = ssr_clip(m, position.xyz, 1.0);
    return -1.0 / c.w;
}
