// What the glossy passes of the screen-space method share (Uludag 2014, sections 4.4.2, 4.4.4,
// 4.4.5): `ssr_visibility` (the max pyramid and the pre-integrated visibility), `ssr_blur` (the
// pre-convolved colour chain) and `ssr_cone` (the cone tracing). They run only when the scene has
// a glossy reflector; CPU twin `src/cpu/ssr_cone.rs`. Every buffer uses the levels of the min
// pyramid (`SsrParams::levels`, shared/ssr.wgsl): level l is ceil(W / 2^l) x ceil(H / 2^l),
// row-major, levels one after another.

// Per dispatch of `ssr_visibility` and `ssr_blur` (`vk::methods::ssr::ConeLevelParams`).
struct ConeLevel {
    level: u32,
    // `ssr_blur`: 0 level 0 from the G-buffer, 1 the horizontal blur of level - 1, 2 the
    // vertical blur and 2 x 2 reduction into level; unused by `ssr_visibility`.
    stage: u32,
    pad0: u32,
    pad1: u32,
    // `ssr_blur`'s level 0 where nothing was drawn (the frame's background).
    background: vec4<f32>,
}

// The view depth (w, along the view axis) of a depth key; an empty key (0, nothing drawn) is
// SSR_CONE_FAR, an f32 stand-in for infinity that keeps the ramps below finite.
const SSR_CONE_FAR: f32 = 3.4028235e38;

fn ssr_cone_depth(q: f32) -> f32 {
    if q == 0.0 {
        return SSR_CONE_FAR;
    }
    return -1.0 / q;
}
